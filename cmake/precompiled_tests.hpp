#pragma once
// The library's precompiled headers and GoogleTest's, shared by every test executable.
#include "precompiled.hpp"

#include <gtest/gtest.h>
