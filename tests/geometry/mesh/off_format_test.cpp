// Tests for off_format (work in progress).
#include <gtest/gtest.h>
