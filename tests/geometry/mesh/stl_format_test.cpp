// Tests for stl_format (work in progress).
#include <gtest/gtest.h>
