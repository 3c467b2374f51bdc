// Intel's Masked Occlusion Culling (MOC) as a side of `sightline bench peers`: renders our
// exported occluder sets (world-space triangles + camera; format in
// crates/eval/src/bench/peer_sets.rs) with MOC's public API, timing each clear + render in
// this thread's CPU time, and answers the line protocol of crates/eval/src/bench/peers.rs.
//
// Same work as ours (`OcclusionBuffer::clear` + `render_occluders`): world-space vertices,
// a model-to-clip matrix, near-plane and frustum clipping, double-sided triangles
// (BACKFACE_NONE). MOC's conventions (MaskedOcclusionCulling.h): the matrix is column-major
// for post-multiplication (clip = M * (x, y, z, 1), element [col * 4 + row]); clip space is
// (x, y, w) with x right, y up, w the view depth (z is ignored, MOC stores 1 / w); near clip at
// w = near; USE_D3D puts screen row 0 at the top, as ours.
//
// Usage: moc_harness avx2|avx512   (then commands on stdin)
//   render SET REPS [DEPTH_OUT] -> {"ns": [...]}; DEPTH_OUT gets the per-pixel 1/w buffer.
//   A set is read once, on its first use (one file per set).
// Build: scripts/peer-bench (g++ with MOC's per-file SIMD flags, as its CMakeLists.txt).

#include <cmath>
#include <iostream>
#include <map>
#include <sstream>

#include "MaskedOcclusionCulling.h"
#include "peer_io.h"

struct Set {
  std::vector<float> verts;  // x y z per vertex, three vertices per triangle
  std::vector<unsigned> idx;
  float mtx[16];
  float near;
  unsigned width, height;
  bool warmed = false;
};

static Set load(const std::string& path) {
  peer_io::File f(path, 1);
  float c[9];
  for (float& v : c) v = f.f32();
  float fov = f.f32();
  Set s;
  s.width = f.u32();
  s.height = f.u32();
  s.near = f.f32();
  uint32_t n = f.u32();
  f.need(uint64_t(n) * 36);
  s.verts.resize(size_t(n) * 9);
  for (float& v : s.verts) v = f.f32();
  s.idx.resize(size_t(n) * 3);
  for (size_t i = 0; i < s.idx.size(); i++) s.idx[i] = unsigned(i);
  // The camera basis of sightline_core::Camera: right = forward x up.
  const float *e = c, *fw = c + 3, *up = c + 6;
  float r[3] = {fw[1] * up[2] - fw[2] * up[1], fw[2] * up[0] - fw[0] * up[2], fw[0] * up[1] - fw[1] * up[0]};
  float rl = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  for (float& v : r) v /= rl;
  float ty = std::tan(fov * float(M_PI) / 360.0f), tx = ty * float(s.width) / float(s.height);
  auto dot = [](const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  for (int k = 0; k < 3; k++) {
    s.mtx[k * 4 + 0] = r[k] / tx;   // clip x
    s.mtx[k * 4 + 1] = up[k] / ty;  // clip y
    s.mtx[k * 4 + 2] = fw[k];       // clip z (unused by MOC)
    s.mtx[k * 4 + 3] = fw[k];       // clip w = view depth
  }
  s.mtx[12] = -dot(r, e) / tx;
  s.mtx[13] = -dot(up, e) / ty;
  s.mtx[14] = -dot(fw, e);
  s.mtx[15] = -dot(fw, e);
  return s;
}

static void render(MaskedOcclusionCulling* moc, const Set& s) {
  moc->ClearBuffer();
  moc->RenderTriangles(s.verts.data(), s.idx.data(), int(s.idx.size() / 3), s.mtx,
                       MaskedOcclusionCulling::BACKFACE_NONE, MaskedOcclusionCulling::CLIP_PLANE_ALL,
                       MaskedOcclusionCulling::VertexLayout(12, 4, 8));
}

int main(int argc, char** argv) {
  std::string want = argc > 1 ? argv[1] : "avx2";
  auto impl = want == "avx512" ? MaskedOcclusionCulling::AVX512 : MaskedOcclusionCulling::AVX2;
  MaskedOcclusionCulling* moc = MaskedOcclusionCulling::Create(impl);
  const char* names[] = {"SSE2", "SSE4.1", "AVX2", "AVX-512"};
  int got = int(moc->GetImplementation());
  peer_io::answer(std::string("{\"impl\": \"") + names[got] + "\", \"requested\": \"" + want + "\"}");
  std::map<std::string, Set> sets;
  unsigned w = 0, h = 0;
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string cmd, path, depth_out;
    int reps = 0;
    in >> cmd >> path >> reps >> depth_out;
    if (cmd == "quit") break;
    try {
      if (cmd != "render" || reps < 1) throw std::runtime_error("unknown command: " + line);
      if (!sets.count(path)) sets.emplace(path, load(path));
      Set& s = sets.at(path);
      if (s.width != w || s.height != h) moc->SetResolution(w = s.width, h = s.height);
      moc->SetNearClipPlane(s.near);
      if (!s.warmed) render(moc, s), s.warmed = true;
      std::vector<uint64_t> ns;
      for (int i = 0; i < reps; i++) {
        uint64_t t = peer_io::thread_cpu_ns();
        render(moc, s);
        ns.push_back(peer_io::thread_cpu_ns() - t);
      }
      if (!depth_out.empty()) {
        std::vector<float> depth(size_t(w) * h);
        moc->ComputePixelDepthBuffer(depth.data(), false);
        std::vector<uint32_t> words = {w, h};
        for (float d : depth) words.push_back(peer_io::bits(d));
        peer_io::write_file(depth_out, 5, words);
      }
      peer_io::answer_ns(ns);
    } catch (const std::exception& e) {
      peer_io::answer_error(e.what());
    }
  }
  MaskedOcclusionCulling::Destroy(moc);
  return 0;
}
