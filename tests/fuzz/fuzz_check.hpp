#pragma once
// A failed property in a fuzz target is a crash libFuzzer reports with the input that caused it.

#include <cstdio>
#include <cstdlib>

#define VOG_FUZZ_CHECK(cond)                                                                 \
  do {                                                                                       \
    if (!(cond)) {                                                                           \
      std::fprintf(stderr, "fuzz property failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
      std::abort();                                                                          \
    }                                                                                        \
  } while (0)
