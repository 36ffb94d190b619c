// Test entry point. Floating-point traps are on (invalid operation, division by zero, overflow):
// a NaN or an infinity produced anywhere in the code under test stops the test where it happens.
#include <gtest/gtest.h>

#include <cfenv>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
#if defined(__GLIBC__) && !defined(CUTSIM_NO_FE_TRAPS)
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
#endif
  return RUN_ALL_TESTS();
}
