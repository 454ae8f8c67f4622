// Catch2 v2 main for ferrule_alloc_tests: the other files in tests/alloc/ replace the global
// operator new/delete to prove that ferrule does not allocate, so they get their own binary.
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>
