/// @file enums_check.cpp
/// @brief Compiles the enum mirror checks of enum_mirrors.h into nimbus_core, so that they hold
///        in every build whether or not anything else includes the header.
#include "core/kernels/enum_mirrors.h"
