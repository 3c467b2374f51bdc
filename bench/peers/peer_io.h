// What the peer harnesses share: reading and writing the exchange files of
// `sightline bench peers` (format: crates/eval/src/bench/peer_sets.rs, version 1), the
// thread's CPU time, and the JSON lines of the protocol (crates/eval/src/bench/peers.rs).
// Our code, not the peers': the peers are only called through their public headers.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <string>
#include <vector>

namespace peer_io {

inline uint64_t thread_cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return uint64_t(ts.tv_sec) * 1000000000ull + uint64_t(ts.tv_nsec);
}

// A whole exchange file after its header has been checked (magic, version, kind).
struct File {
  std::vector<unsigned char> bytes;
  size_t at = 16;
  File(const std::string& path, uint32_t kind) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw std::runtime_error("cannot open " + path);
    unsigned char buf[1 << 16];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
    std::fclose(f);
    if (bytes.size() < 16 || std::memcmp(bytes.data(), "SLPEERS\0", 8) != 0)
      throw std::runtime_error(path + ": not a peer-bench file");
    at = 8;
    if (u32() != 1) throw std::runtime_error(path + ": unsupported version");
    if (u32() != kind) throw std::runtime_error(path + ": wrong kind");
  }
  void need(uint64_t n) const {
    if (n > bytes.size() - at) throw std::runtime_error("truncated peer-bench file");
  }
  uint32_t u32() {
    need(4);
    uint32_t v;
    std::memcpy(&v, &bytes[at], 4);  // little-endian host (x86-64)
    at += 4;
    return v;
  }
  float f32() {
    need(4);
    float v;
    std::memcpy(&v, &bytes[at], 4);
    at += 4;
    return v;
  }
};

// Writes header + payload.
inline void write_file(const std::string& path, uint32_t kind, const std::vector<uint32_t>& words) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write " + path);
  uint32_t head[2] = {1, kind};
  std::fwrite("SLPEERS\0", 1, 8, f);
  std::fwrite(head, 4, 2, f);
  std::fwrite(words.data(), 4, words.size(), f);
  std::fclose(f);
}

inline uint32_t bits(float x) {
  uint32_t v;
  std::memcpy(&v, &x, 4);
  return v;
}

// One answer line: {"ns": [..]}.
inline void answer_ns(const std::vector<uint64_t>& ns) {
  std::printf("{\"ns\": [");
  for (size_t i = 0; i < ns.size(); i++) std::printf("%s%llu", i ? ", " : "", (unsigned long long)ns[i]);
  std::printf("]}\n");
  std::fflush(stdout);
}

inline void answer(const std::string& json) {
  std::printf("%s\n", json.c_str());
  std::fflush(stdout);
}

inline void answer_error(const std::string& message) {
  std::string m;
  for (char c : message) m += (c == '"' || c == '\\') ? '\'' : c;
  answer("{\"error\": \"" + m + "\"}");
}

}  // namespace peer_io
