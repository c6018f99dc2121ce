// Tests for ply_format (work in progress).
#include <gtest/gtest.h>
