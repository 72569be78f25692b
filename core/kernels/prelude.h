/// @file prelude.h
/// @brief C++ side of the single-source kernels: maps the GLSL subset onto glm.
///
/// The files core/kernels/*.glsl are written once in a common subset of GLSL 4.30 and C++20
/// (see DESIGN.md, "The GLSL port"). In C++ they are included inside namespace nimbus::kern
/// after this prelude; in GLSL they follow prelude.glsl. Rules: float literals carry `f`, no
/// struct constructor calls (C++20 parenthesised aggregate init: clang 14 lacks it), no
/// swizzles, no array constructors, no recursion, parameters passed by IN/OUT/INOUT.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>

#define IN(T) const T&
#define OUT(T) T&
#define INOUT(T) T&
#define NB_FN inline

namespace nimbus::kern {
using namespace glm;
using uint = std::uint32_t;
} // namespace nimbus::kern
