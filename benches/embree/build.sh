#!/bin/sh
# Builds target/bvh-rays/embree_rays against the Embree 4 library shipped in the `embreex`
# wheel (`pip install embreex`). `cargo bench --bench bvh` then times Embree on the same rays.
set -eu
cd "$(dirname "$0")/../.."
libdir=$(python3 -c 'import embreex, os; print(os.path.join(os.path.dirname(os.path.dirname(embreex.__file__)), "embreex.libs"))')
lib=$(ls "$libdir"/libembree4*.so* | head -n 1)
mkdir -p target/bvh-rays
cc -O2 -std=c11 -Wall -o target/bvh-rays/embree_rays benches/embree/embree_rays.c \
  "$lib" -Wl,-rpath,"$libdir" -lm
echo "built target/bvh-rays/embree_rays ($lib)"
