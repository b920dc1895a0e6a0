//! The check that a `repr(C)` Rust struct uploaded to the GPU has the layout its WGSL twin
//! gets under WGSL's memory layout rules (WGSL spec §14.4, "Memory Layout"), as naga's
//! layouter computes it: the same size and the same offset for each member, in order.
//!
//! For tests, in `src` (`#[cfg(test)]` modules) and in `tests/` alike:
//! [`assert_wgsl_layout!`](crate::assert_wgsl_layout) names the Rust fields, and
//! [`assert_layout`] compares. A vertex buffer's struct meets WGSL through `@location`s
//! instead: [`assert_vertex_layout`] checks its stride, offsets and locations.

use wgpu::naga;

/// The layout naga gives one WGSL struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WgslStruct {
    /// Size in bytes (rounded up to its alignment: the array stride).
    pub size: u32,
    /// Each member's name and byte offset, in declaration order.
    pub members: Vec<(String, u32)>,
}

/// The WGSL `source` parsed by naga, or why it does not parse.
fn parse(source: &str) -> Result<naga::Module, String> {
    naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("the WGSL does not parse: {}", e.emit_to_string(source)))
}

/// The struct `name` of `module`: its type handle and members.
fn find_struct<'m>(
    module: &'m naga::Module,
    name: &str,
) -> Result<(naga::Handle<naga::Type>, &'m [naga::StructMember]), String> {
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .ok_or_else(|| format!("no type `{name}` in the WGSL"))?;
    match &ty.inner {
        naga::TypeInner::Struct { members, .. } => Ok((handle, members)),
        _ => Err(format!("`{name}` is not a struct in the WGSL")),
    }
}

/// The layout of the struct `name` in the WGSL `source`, or why there is none (the source
/// does not parse, has no layout, or has no such struct).
pub fn wgsl_struct(source: &str, name: &str) -> Result<WgslStruct, String> {
    let module = parse(source)?;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| format!("the WGSL has no layout: {e}"))?;
    let (handle, members) = find_struct(&module, name)?;
    Ok(WgslStruct {
        size: layouter[handle].size,
        members: members
            .iter()
            .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
            .collect(),
    })
}

/// Panics unless the WGSL struct `wgsl_name` in `source` has `rust_size` bytes and one member
/// per entry of `rust_fields` (name, byte offset), at the same offsets in the same order.
/// `rust_name` names the Rust side in the message. Prefer
/// [`assert_wgsl_layout!`](crate::assert_wgsl_layout), which fills in size and offsets.
pub fn assert_layout(
    source: &str,
    wgsl_name: &str,
    rust_name: &str,
    rust_size: usize,
    rust_fields: &[(&str, usize)],
) {
    let wgsl = wgsl_struct(source, wgsl_name).unwrap_or_else(|e| panic!("{wgsl_name}: {e}"));
    assert_eq!(
        wgsl.size as usize, rust_size,
        "WGSL struct {wgsl_name} is {} bytes, Rust {rust_name} {rust_size}",
        wgsl.size
    );
    let wgsl_names: Vec<&str> = wgsl.members.iter().map(|(n, _)| n.as_str()).collect();
    let rust_names: Vec<&str> = rust_fields.iter().map(|(n, _)| *n).collect();
    assert_eq!(
        wgsl.members.len(),
        rust_fields.len(),
        "WGSL struct {wgsl_name} has members {wgsl_names:?}, Rust {rust_name} fields {rust_names:?}"
    );
    for ((wn, wo), (rn, ro)) in wgsl.members.iter().zip(rust_fields) {
        assert_eq!(
            *wo as usize, *ro,
            "WGSL {wgsl_name}.{wn} is at byte {wo}, Rust {rust_name}.{rn} at {ro}"
        );
    }
}

/// `assert_wgsl_layout!(SOURCE, "WgslName", RustType { field, field, … })`: panics unless
/// the WGSL struct `WgslName` in `SOURCE` (a `&str`) has the size of `RustType` and its
/// members lie at the listed fields' offsets, in order (see
/// [`assert_layout`](super::wgsl_layout::assert_layout)). List every field.
#[macro_export]
macro_rules! assert_wgsl_layout {
    ($source:expr, $wgsl:expr, $ty:ident { $($field:ident),+ $(,)? }) => {
        $crate::view::gpu::wgsl_layout::assert_layout(
            &$source,
            $wgsl,
            stringify!($ty),
            ::std::mem::size_of::<$ty>(),
            &[$((stringify!($field), ::std::mem::offset_of!($ty, $field))),+],
        )
    };
}

/// The `@location`s of the members of struct `name` in the WGSL `source` (a vertex input),
/// or why there are none.
pub fn wgsl_locations(source: &str, name: &str) -> Result<Vec<Option<u32>>, String> {
    let module = parse(source)?;
    let (_, members) = find_struct(&module, name)?;
    Ok(members
        .iter()
        .map(|m| match m.binding {
            Some(naga::Binding::Location { location, .. }) => Some(location),
            _ => None,
        })
        .collect())
}

/// The array stride and element type (as WGSL writes it, e.g. `vec4<f32>`) of the
/// array-typed global variable `name` in the WGSL `source` (a storage buffer read as an array
/// of vectors), or why there is none.
pub fn wgsl_array(source: &str, name: &str) -> Result<(u32, String), String> {
    let module = parse(source)?;
    let (_, var) = module
        .global_variables
        .iter()
        .find(|(_, v)| v.name.as_deref() == Some(name))
        .ok_or_else(|| format!("no global `{name}` in the WGSL"))?;
    let naga::TypeInner::Array { base, stride, .. } = module.types[var.ty].inner else {
        return Err(format!("`{name}` is not an array in the WGSL"));
    };
    let element = match module.types[base].inner {
        naga::TypeInner::Vector { size, scalar } => {
            let kind = match scalar.kind {
                naga::ScalarKind::Float => "f",
                naga::ScalarKind::Uint => "u",
                naga::ScalarKind::Sint => "i",
                _ => "?",
            };
            format!("vec{}<{kind}{}>", size as u8, scalar.width * 8)
        }
        ref other => format!("{other:?}"),
    };
    Ok((stride, element))
}

/// Panics unless the vertex buffer `layout` has the stride `size` of its `repr(C)` struct,
/// its attributes at the struct's field `offsets` (attribute order), and the WGSL vertex
/// input `input` of `source` takes them at the attributes' locations.
pub fn assert_vertex_layout(
    layout: &wgpu::VertexBufferLayout<'_>,
    size: usize,
    offsets: &[usize],
    source: &str,
    input: &str,
) {
    assert_eq!(layout.array_stride as usize, size, "{input}: stride");
    let got: Vec<usize> = layout
        .attributes
        .iter()
        .map(|a| a.offset as usize)
        .collect();
    assert_eq!(got, offsets, "{input}: attribute offsets");
    let want: Vec<Option<u32>> = layout
        .attributes
        .iter()
        .map(|a| Some(a.shader_location))
        .collect();
    let locations = wgsl_locations(source, input).unwrap_or_else(|e| panic!("{input}: {e}"));
    assert_eq!(locations, want, "{input}: locations");
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOURCE: &str = "struct P { a: vec3<f32>, b: f32, c: vec2<u32> }
        @group(0) @binding(0) var<uniform> p: P;";

    #[repr(C)]
    struct Good {
        a: [f32; 3],
        b: f32,
        c: [u32; 2],
        _pad: [u32; 2],
    }

    #[repr(C)]
    struct Shifted {
        a: [f32; 4],
        b: f32,
        c: [u32; 2],
        _pad: u32,
    }

    #[test]
    fn naga_pads_the_struct_to_its_alignment() {
        let p = wgsl_struct(SOURCE, "P").unwrap();
        assert_eq!(p.size, 32);
        assert_eq!(
            p.members,
            [("a".into(), 0), ("b".into(), 12), ("c".into(), 16)]
        );
        assert!(
            wgsl_struct(SOURCE, "Q")
                .unwrap_err()
                .contains("no type `Q`")
        );
    }

    #[test]
    fn a_matching_struct_passes() {
        let g = Good {
            a: [0.0; 3],
            b: 0.0,
            c: [0; 2],
            _pad: [0; 2],
        };
        let _ = (g.a, g.b, g.c, g._pad);
        assert_layout(
            SOURCE,
            "P",
            "Good",
            std::mem::size_of::<Good>(),
            &[
                ("a", std::mem::offset_of!(Good, a)),
                ("b", std::mem::offset_of!(Good, b)),
                ("c", std::mem::offset_of!(Good, c)),
            ],
        );
    }

    #[test]
    #[should_panic(expected = "WGSL P.b is at byte 12, Rust Shifted.b at 16")]
    fn a_shifted_member_is_named() {
        let s = Shifted {
            a: [0.0; 4],
            b: 0.0,
            c: [0; 2],
            _pad: 0,
        };
        let _ = (s.a, s.b, s.c, s._pad);
        assert_layout(
            SOURCE,
            "P",
            "Shifted",
            32,
            &[
                ("a", std::mem::offset_of!(Shifted, a)),
                ("b", std::mem::offset_of!(Shifted, b)),
                ("c", std::mem::offset_of!(Shifted, c)),
            ],
        );
    }

    const VERTEX_SOURCE: &str = "struct In { @location(0) p: vec3<f32>, @location(2) n: u32 }
        @vertex fn vs(i: In) -> @builtin(position) vec4<f32> { return vec4<f32>(i.p, 1.0); }";

    fn vertex_layout(second: u32) -> Vec<wgpu::VertexAttribute> {
        vec![
            wgpu::VertexAttribute {
                format: wgpu::VertexFormat::Float32x3,
                offset: 0,
                shader_location: 0,
            },
            wgpu::VertexAttribute {
                format: wgpu::VertexFormat::Uint32,
                offset: 12,
                shader_location: second,
            },
        ]
    }

    #[test]
    fn array_strides_and_elements_are_read() {
        let source = "@group(0) @binding(0) var<storage, read> a: array<vec4<f32>>;
            @group(0) @binding(1) var<storage, read> b: array<vec2<u32>>;";
        assert_eq!(wgsl_array(source, "a").unwrap(), (16, "vec4<f32>".into()));
        assert_eq!(wgsl_array(source, "b").unwrap(), (8, "vec2<u32>".into()));
        assert!(
            wgsl_array(source, "c")
                .unwrap_err()
                .contains("no global `c`")
        );
    }

    #[test]
    fn vertex_locations_are_read_from_the_wgsl_input() {
        assert_eq!(
            wgsl_locations(VERTEX_SOURCE, "In").unwrap(),
            [Some(0), Some(2)]
        );
        let attributes = vertex_layout(2);
        let layout = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attributes,
        };
        assert_vertex_layout(&layout, 16, &[0, 12], VERTEX_SOURCE, "In");
    }

    #[test]
    #[should_panic(expected = "In: locations")]
    fn a_wrong_vertex_location_is_named() {
        let attributes = vertex_layout(1);
        let layout = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attributes,
        };
        assert_vertex_layout(&layout, 16, &[0, 12], VERTEX_SOURCE, "In");
    }
}
