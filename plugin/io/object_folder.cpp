/// @file object_folder.cpp
/// @brief objectFolder() (object_folder.h).
#include "plugin/io/object_folder.h"

#include <dlfcn.h>

namespace nimbus::io {

std::string objectFolder(const void* address) {
    Dl_info info{};
    if (dladdr(address, &info) == 0 || !info.dli_fname) return {};
    const std::string self = info.dli_fname;
    const std::size_t slash = self.find_last_of('/');
    return slash == std::string::npos ? std::string() : self.substr(0, slash);
}

} // namespace nimbus::io
