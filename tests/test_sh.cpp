#include <gtest/gtest.h>
TEST(Dummy, A) {}
