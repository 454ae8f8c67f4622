// FERRULE_CHECK(cond): an invariant of a fuzz target. A violation prints the condition and
// traps, so libFuzzer saves the input that broke it.
#pragma once

#include <cstdio>

#define FERRULE_CHECK(cond)                                                                        \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            std::fprintf(stderr, "invariant violated: %s (%s:%d)\n", #cond, __FILE__, __LINE__);   \
            __builtin_trap();                                                                      \
        }                                                                                          \
    } while (0)
