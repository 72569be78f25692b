/// @file object_folder.h
/// @brief The folder of the executable or shared object a piece of code was linked into: where
///        Nimbus looks for the files it ships beside itself (libnimbus_image.so,
///        nimbus-vdb-reader).
#pragma once

#include <string>

namespace nimbus::io {

/// The folder of the executable or shared object that holds @p address (dladdr), "" when it
/// cannot be told. Pass the address of one of the caller's own functions with internal linkage,
/// so that no other object's copy of it can stand in.
std::string objectFolder(const void* address);

} // namespace nimbus::io
