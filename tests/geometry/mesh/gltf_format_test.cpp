// Tests for gltf_format (work in progress).
#include <gtest/gtest.h>
