// tinybvh as a side of `sightline bench peers`: builds its BVH over our exported scene and
// casts our exported rays (formats in crates/eval/src/bench/peer_sets.rs), timing in this
// thread's CPU time, and answers the line protocol of crates/eval/src/bench/peers.rs.
//
// Layout: BVH8_CPU, the layout tiny_bvh.h's README calls the fastest on CPU (AVX2 8-wide
// traversal; its speedtest ranks it above BVH4_CPU and BVH_SoA for closest hit). Its Build is
// BVH::BuildDefault (BuildAVX: the binned SAH builder, same tree as BVH::Build, faster),
// then Compact and the conversion to the 8-wide layout; the build time covers all of it.
// Compiled with NO_THREADED_BUILDS so the build is one thread, as ours.
//
// Rays: tinybvh has no t_min and normalises directions, so a ray (o, d, t_min, t_max) is cast
// as (o + t_min d, d / |d|, (t_max - t_min) |d|) and its hit distance mapped back to our units
// (t_min + t / |d|); this happens outside the timed loop.
//
// Usage: tinybvh_harness   (then commands on stdin)
//   scene MESH -> {"triangles": n};  rays RAYS -> {"rays": n} (loads or reloads);  build -> {"ns": [n]}
//   trace RAYS REPS [HITS_OUT] -> {"ns": [...]}
// Build: scripts/peer-bench (g++ -O3 -mavx2 -mfma -DNO_THREADED_BUILDS).

#define TINYBVH_IMPLEMENTATION
#include "tiny_bvh.h"

#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "peer_io.h"

using namespace tinybvh;

struct RaySet {
  std::vector<float> o, d;        // 3 per ray, origin moved to t_min, unit direction
  std::vector<float> tmin, scale, tfar;  // per ray: t_min, 1/|d|, far distance
};

static std::vector<bvhvec4> verts;
static std::vector<uint32_t> indices;
static std::unique_ptr<BVH8_CPU> bvh;
static std::map<std::string, RaySet> ray_sets;

static void load_scene(const std::string& path) {
  peer_io::File f(path, 2);
  uint32_t nv = f.u32(), nt = f.u32();
  f.need(uint64_t(nv) * 12 + uint64_t(nt) * 12);
  verts.assign(nv, bvhvec4(0, 0, 0, 0));
  for (auto& v : verts) v.x = f.f32(), v.y = f.f32(), v.z = f.f32();
  indices.resize(size_t(nt) * 3);
  for (auto& i : indices) {
    i = f.u32();
    if (i >= nv) throw std::runtime_error("index out of range");
  }
  bvh.reset();
}

static RaySet load_rays(const std::string& path) {
  peer_io::File f(path, 3);
  uint32_t n = f.u32();
  f.need(uint64_t(n) * 32);
  RaySet s;
  for (uint32_t i = 0; i < n; i++) {
    float o[3], d[3];
    for (float& v : o) v = f.f32();
    for (float& v : d) v = f.f32();
    float t0 = f.f32(), t1 = f.f32();
    float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) s.o.push_back(o[k] + t0 * d[k]), s.d.push_back(d[k] / len);
    s.tmin.push_back(t0);
    s.scale.push_back(1.0f / len);
    s.tfar.push_back(std::isfinite(t1) ? (t1 - t0) * len : BVH_FAR);
  }
  return s;
}

static uint64_t build() {
  uint64_t t = peer_io::thread_cpu_ns();
  bvh = std::make_unique<BVH8_CPU>();
  bvh->Build(verts.data(), indices.data(), uint32_t(indices.size() / 3));
  return peer_io::thread_cpu_ns() - t;
}

static std::vector<uint64_t> trace(const RaySet& s, int reps, const std::string& hits_out) {
  size_t n = s.tmin.size();
  std::vector<Ray> rays(n);
  std::vector<uint64_t> ns;
  for (int rep = 0; rep < reps; rep++) {
    for (size_t i = 0; i < n; i++) {  // untimed: fresh rays
      const float *o = &s.o[3 * i], *d = &s.d[3 * i];
      rays[i] = Ray(bvhvec3(o[0], o[1], o[2]), bvhvec3(d[0], d[1], d[2]), s.tfar[i]);
      rays[i].hit.prim = 0xFFFFFFFFu;
    }
    uint64_t t = peer_io::thread_cpu_ns();
    for (size_t i = 0; i < n; i++) bvh->Intersect(rays[i]);
    ns.push_back(peer_io::thread_cpu_ns() - t);
  }
  if (!hits_out.empty()) {
    std::vector<uint32_t> words = {uint32_t(n)};
    for (size_t i = 0; i < n; i++) {
      bool hit = rays[i].hit.prim != 0xFFFFFFFFu && rays[i].hit.t < s.tfar[i];
      words.push_back(hit ? rays[i].hit.prim : 0xFFFFFFFFu);
      words.push_back(peer_io::bits(hit ? s.tmin[i] + rays[i].hit.t * s.scale[i] : INFINITY));
    }
    peer_io::write_file(hits_out, 4, words);
  }
  return ns;
}

int main() {
  peer_io::answer("{\"layout\": \"BVH8_CPU\", \"build\": \"BVH8_CPU::Build (BuildAVX binned SAH, "
                  "Compact, 8-wide conversion), one thread\"}");
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string cmd, path, out;
    int reps = 0;
    in >> cmd >> path >> reps >> out;
    if (cmd == "quit") break;
    try {
      if (cmd == "scene") {
        load_scene(path);
        peer_io::answer("{\"triangles\": " + std::to_string(indices.size() / 3) + "}");
      } else if (cmd == "rays") {
        ray_sets[path] = load_rays(path);  // (re)loads: a file may be rewritten per scene
        peer_io::answer("{\"rays\": " + std::to_string(ray_sets.at(path).tmin.size()) + "}");
      } else if (cmd == "build") {
        if (indices.empty()) throw std::runtime_error("no scene loaded");
        peer_io::answer_ns({build()});
      } else if (cmd == "trace") {
        if (!bvh) throw std::runtime_error("no BVH built");
        if (!ray_sets.count(path)) throw std::runtime_error("rays not loaded: " + path);
        if (reps < 1) throw std::runtime_error("REPS must be at least 1");
        peer_io::answer_ns(trace(ray_sets.at(path), reps, out));
      } else {
        throw std::runtime_error("unknown command: " + line);
      }
    } catch (const std::exception& e) {
      peer_io::answer_error(e.what());
    }
  }
  return 0;
}
