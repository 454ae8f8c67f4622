// Catch2 v2 main for ferrule_tests (all test cases under tests/<area>/).
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>
