/* Times Embree 4 on the ray sets `cargo bench --bench bvh` writes (target/bvh-rays/), one
 * thread, rtcIntersect1 / rtcOccluded1 per ray. Driven by the bench over stdin/stdout so the
 * two are measured interleaved in one run; see benches/embree/README.md.
 *
 * Protocol: `embree_rays DIR` loads DIR/triangles.f32 and DIR/{camera,diffuse}.rays, builds
 * the scene, prints `ready <build ms>`, then answers each stdin line `SET QUERY` (QUERY:
 * closest, occluded, or closest8: rtcIntersect8 on packets of eight consecutive rays, the
 * set's order kept) with `<seconds> <hits>` after one pass over the set. The first pass of
 * each SET QUERY also writes DIR/embree-SET-QUERY.f32: per ray the hit distance (closest) or
 * 1/0 (occluded), +inf for a miss, followed by the hit triangle index as u32 (closest only).
 *
 * The few Embree 4 declarations used are written out here (values from embree4/rtcore*.h) so
 * the program needs only the shared library from the `embreex` wheel. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct RTCDeviceTy *RTCDevice;
typedef struct RTCSceneTy *RTCScene;
typedef struct RTCGeometryTy *RTCGeometry;
enum { RTC_GEOMETRY_TYPE_TRIANGLE = 0 };
enum { RTC_BUFFER_TYPE_INDEX = 0, RTC_BUFFER_TYPE_VERTEX = 1 };
enum { RTC_FORMAT_UINT3 = 0x5003, RTC_FORMAT_FLOAT3 = 0x9003 };
enum { RTC_BUILD_QUALITY_LOW = 0, RTC_BUILD_QUALITY_MEDIUM = 1, RTC_BUILD_QUALITY_HIGH = 2 };
#define RTC_INVALID_GEOMETRY_ID ((unsigned)-1)

struct __attribute__((aligned(16))) RTCRay {
  float org_x, org_y, org_z, tnear;
  float dir_x, dir_y, dir_z, time;
  float tfar;
  unsigned mask, id, flags;
};
struct __attribute__((aligned(16))) RTCHit {
  float Ng_x, Ng_y, Ng_z, u, v;
  unsigned primID, geomID;
  unsigned instID[1];
  unsigned spare[4]; /* room for instPrimID and deeper instancing if the library has them */
};
struct RTCRayHit {
  struct RTCRay ray;
  struct RTCHit hit;
};
/* Eight rays and hits, SoA (embree4/rtcore_ray.h's RTCRayHit8). */
struct __attribute__((aligned(32))) RTCRayHit8 {
  float org_x[8], org_y[8], org_z[8], tnear[8];
  float dir_x[8], dir_y[8], dir_z[8], time[8];
  float tfar[8];
  unsigned mask[8], id[8], flags[8];
  float Ng_x[8], Ng_y[8], Ng_z[8], u[8], v[8];
  unsigned primID[8], geomID[8];
  unsigned instID[1][8];
  unsigned spare[4][8]; /* as in RTCHit */
};

RTCDevice rtcNewDevice(const char *config);
int rtcGetDeviceError(RTCDevice device);
RTCScene rtcNewScene(RTCDevice device);
void rtcSetSceneBuildQuality(RTCScene scene, int quality);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry geometry, int type, unsigned slot, int format,
                              size_t byteStride, size_t itemCount);
void rtcCommitGeometry(RTCGeometry geometry);
unsigned rtcAttachGeometry(RTCScene scene, RTCGeometry geometry);
void rtcReleaseGeometry(RTCGeometry geometry);
void rtcCommitScene(RTCScene scene);
void rtcIntersect1(RTCScene scene, struct RTCRayHit *rayhit, void *args);
void rtcOccluded1(RTCScene scene, struct RTCRay *ray, void *args);
void rtcIntersect8(const int *valid, RTCScene scene, struct RTCRayHit8 *rayhit, void *args);

static float *read_floats(const char *dir, const char *name, size_t *count) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "embree_rays: cannot open %s\n", path);
    exit(1);
  }
  fseek(f, 0, SEEK_END);
  long bytes = ftell(f);
  fseek(f, 0, SEEK_SET);
  float *data = malloc(bytes);
  if (fread(data, 1, bytes, f) != (size_t)bytes) {
    fprintf(stderr, "embree_rays: short read on %s\n", path);
    exit(1);
  }
  fclose(f);
  *count = bytes / sizeof(float);
  return data;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

struct RaySet {
  const char *name;
  float *rays; /* ox oy oz dx dy dz per ray */
  size_t n;
  int dumped[3];
};

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: embree_rays DIR [low|medium|high]\n");
    return 2;
  }
  const char *dir = argv[1];
  int quality = RTC_BUILD_QUALITY_MEDIUM;
  if (argc > 2 && !strcmp(argv[2], "high")) quality = RTC_BUILD_QUALITY_HIGH;
  if (argc > 2 && !strcmp(argv[2], "low")) quality = RTC_BUILD_QUALITY_LOW;
  size_t nf;
  float *tris = read_floats(dir, "triangles.f32", &nf);
  size_t ntri = nf / 9;
  struct RaySet sets[2] = {{"camera", 0, 0, {0, 0, 0}}, {"diffuse", 0, 0, {0, 0, 0}}};
  for (int s = 0; s < 2; s++) {
    char name[64];
    snprintf(name, sizeof name, "%s.rays", sets[s].name);
    size_t n;
    sets[s].rays = read_floats(dir, name, &n);
    sets[s].n = n / 6;
  }

  RTCDevice device = rtcNewDevice("threads=1");
  if (!device) {
    fprintf(stderr, "embree_rays: rtcNewDevice failed (%d)\n", rtcGetDeviceError(NULL));
    return 1;
  }
  double t0 = now();
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneBuildQuality(scene, quality);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  float *v = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                     3 * sizeof(float), ntri * 3);
  unsigned *idx = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                          3 * sizeof(unsigned), ntri);
  memcpy(v, tris, ntri * 9 * sizeof(float));
  for (size_t i = 0; i < ntri * 3; i++) idx[i] = (unsigned)i;
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  int err = rtcGetDeviceError(device);
  if (err) {
    fprintf(stderr, "embree_rays: scene build failed (error %d)\n", err);
    return 1;
  }
  printf("ready %.1f %zu\n", (now() - t0) * 1e3, ntri);
  fflush(stdout);

  char line[256];
  while (fgets(line, sizeof line, stdin)) {
    char set_name[64], query[64];
    if (sscanf(line, "%63s %63s", set_name, query) != 2) continue;
    struct RaySet *set = NULL;
    for (int s = 0; s < 2; s++)
      if (!strcmp(set_name, sets[s].name)) set = &sets[s];
    int closest8 = !strcmp(query, "closest8");
    int closest = closest8 || !strcmp(query, "closest");
    if (!set || (!closest && strcmp(query, "occluded"))) {
      printf("error unknown set or query: %s", line);
      fflush(stdout);
      continue;
    }
    int kind = closest + closest8;
    int dump = !set->dumped[kind];
    float *out_t = dump ? malloc(set->n * sizeof(float)) : NULL;
    unsigned *out_id = dump ? malloc(set->n * sizeof(unsigned)) : NULL;
    size_t hits = 0;
    const float *r = set->rays;
    double start = now();
    if (closest8) {
      /* Whole packets of eight; the last few rays (if any) in a packet of fewer. */
      static const int all[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
      for (size_t i = 0; i < set->n; i += 8, r += 48) {
        struct RTCRayHit8 rh;
        int valid[8];
        size_t k = set->n - i < 8 ? set->n - i : 8;
        for (size_t j = 0; j < 8; j++) {
          const float *q = r + 6 * (j < k ? j : 0);
          valid[j] = j < k ? -1 : 0;
          rh.org_x[j] = q[0]; rh.org_y[j] = q[1]; rh.org_z[j] = q[2];
          rh.dir_x[j] = q[3]; rh.dir_y[j] = q[4]; rh.dir_z[j] = q[5];
          rh.tnear[j] = 0.0f; rh.tfar[j] = INFINITY; rh.time[j] = 0.0f;
          rh.mask[j] = (unsigned)-1; rh.id[j] = 0; rh.flags[j] = 0;
          rh.geomID[j] = RTC_INVALID_GEOMETRY_ID;
          rh.instID[0][j] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect8(k == 8 ? all : valid, scene, &rh, NULL);
        for (size_t j = 0; j < k; j++) {
          int hit = rh.geomID[j] != RTC_INVALID_GEOMETRY_ID;
          hits += hit;
          if (dump) {
            out_t[i + j] = hit ? rh.tfar[j] : INFINITY;
            out_id[i + j] = hit ? rh.primID[j] : (unsigned)-1;
          }
        }
      }
    } else if (closest) {
      for (size_t i = 0; i < set->n; i++, r += 6) {
        struct RTCRayHit rh;
        rh.ray.org_x = r[0]; rh.ray.org_y = r[1]; rh.ray.org_z = r[2];
        rh.ray.dir_x = r[3]; rh.ray.dir_y = r[4]; rh.ray.dir_z = r[5];
        rh.ray.tnear = 0.0f; rh.ray.tfar = INFINITY; rh.ray.time = 0.0f;
        rh.ray.mask = (unsigned)-1; rh.ray.id = 0; rh.ray.flags = 0;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &rh, NULL);
        int hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        hits += hit;
        if (dump) {
          out_t[i] = hit ? rh.ray.tfar : INFINITY;
          out_id[i] = hit ? rh.hit.primID : (unsigned)-1;
        }
      }
    } else {
      for (size_t i = 0; i < set->n; i++, r += 6) {
        struct RTCRay ray;
        ray.org_x = r[0]; ray.org_y = r[1]; ray.org_z = r[2];
        ray.dir_x = r[3]; ray.dir_y = r[4]; ray.dir_z = r[5];
        ray.tnear = 0.0f; ray.tfar = INFINITY; ray.time = 0.0f;
        ray.mask = (unsigned)-1; ray.id = 0; ray.flags = 0;
        rtcOccluded1(scene, &ray, NULL);
        int hit = ray.tfar < 0.0f; /* Embree sets tfar to -inf on a hit */
        hits += hit;
        if (dump) out_t[i] = hit ? 1.0f : INFINITY;
      }
    }
    double secs = now() - start;
    if (dump) {
      char path[4096], tmp[4200];
      snprintf(path, sizeof path, "%s/embree-%s-%s.f32", dir, set->name, query);
      snprintf(tmp, sizeof tmp, "%s.tmp", path);
      FILE *f = fopen(tmp, "wb");
      fwrite(out_t, sizeof(float), set->n, f);
      if (closest) fwrite(out_id, sizeof(unsigned), set->n, f);
      fclose(f);
      rename(tmp, path);
      free(out_t);
      free(out_id);
      set->dumped[kind] = 1;
    }
    printf("%.6f %zu\n", secs, hits);
    fflush(stdout);
  }
  return 0;
}
