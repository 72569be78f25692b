/// @file scene_setup.h
/// @brief Ties a parsed scene file to the colour system: light colours from the file's
/// `color_space` into the working space, and the output colour space, display and view checked
/// against the OCIO config, with errors that name the file and the key.
#pragma once

#include <string>

#include "plugin/io/color.h"
#include "plugin/io/scene_file.h"

namespace nimbus::io {

/// The working (rendering) space: "ACEScg" in the built-in config, the scene_linear role of a
/// user's $OCIO config.
std::string workingSpace(const ColorSystem& cs);

/// Converts sun and sky colours to the working space and checks output.colorSpace,
/// output.display and output.view. @throws SceneError naming the file and the key.
void resolveColours(SceneFile& f, const ColorSystem& cs);

} // namespace nimbus::io
