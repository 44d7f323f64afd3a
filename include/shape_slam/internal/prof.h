#pragma once
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
namespace prof {
struct Acc { double s = 0; long n = 0; };
inline std::map<std::string, Acc>& Table() {
  struct T { std::map<std::string, Acc> m; ~T() { for (auto& [k, v] : m) std::fprintf(stderr, "PROF %-28s %8.3f s %7ld\n", k.c_str(), v.s, v.n); } };
  static T t; return t.m;
}
struct Scope {
  const char* name; std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  explicit Scope(const char* n) : name(n) {}
  ~Scope() { auto& a = Table()[name]; a.s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); ++a.n; }
};
inline void Count(const char* name) { ++Table()[name].n; }
}
#define PROF_CAT2(a, b) a##b
#define PROF_CAT(a, b) PROF_CAT2(a, b)
#define PROF(n) prof::Scope PROF_CAT(prof_scope_, __LINE__)(n)
