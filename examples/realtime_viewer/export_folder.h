/// @file export_folder.h
/// @brief Reads a folder written by `nimbus export-glsl` (docs/realtime.md, "Export for
///        engines"): march.comp, params.json and params.bin, into what an engine needs to run
///        the pass. Everything is taken from params.json (member offsets, bindings, buffer sizes,
///        workgroups, passes, the output layout); nothing about the block is hard-coded here.
///        No GL: the viewer (viewer.cpp) makes the buffers and the program from this.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace viewer {

/// One member of the parameter block (params.json's parameter_block.members[i]).
struct Member {
    std::string type;       ///< "vec4", "float", "int" or "uint"
    std::size_t offset = 0; ///< std430 byte offset in the block
};

/// A shader storage buffer of params.json's buffers other than the parameter block. Those with
/// a "file" (the Mie table, the multiple-scattering grids) are data the pass reads: `data` holds
/// the file, uploaded once. The others the pass writes (the output, the counters): made `bytes`
/// long and zeroed before each frame's first dispatch.
struct WorkBuffer {
    unsigned binding = 0;
    std::string block;
    std::size_t bytes = 0;
    std::vector<std::uint8_t> data; ///< the file's bytes; empty for a buffer the pass writes
};

/// A 3D texture of params.json's "textures" (field.evaluation = "rgba": the noise tiles in
/// Olajos' channel layout): GL_RGBA8, GL_LINEAR, GL_REPEAT, bound to its unit; `data` holds its
/// file (4 bytes a texel, x fastest).
struct TextureFile {
    unsigned unit = 0;
    int size[3] = {0, 0, 0};
    std::vector<std::uint8_t> data;
};

struct ExportFolder {
    std::string shader;               ///< the text of march.comp
    std::vector<std::uint8_t> params; ///< params.bin: the block for the frame's first pass
    unsigned paramBinding = 0;        ///< parameter_block.binding
    std::map<std::string, Member> members;
    std::vector<WorkBuffer> buffers;
    std::vector<TextureFile> textures;
    int width = 0, height = 0;      ///< image
    unsigned groups[3] = {1, 1, 1}; ///< dispatch.groups
    int passes = 1;                 ///< dispatch.passes (sampleIndex = 0 .. passes - 1)
    unsigned outputBinding = 0;     ///< output.buffer_binding
    int floatsPerPixel = 0;         ///< output.floats_per_pixel
    int rgbaIndex[4] = {-1, -1, -1,
                        -1}; ///< output.floats: "sum w*R", "sum w*G", "sum w*B", "sum w*alpha"
    int weightIndex = -1;    ///< output.floats: "sum w"
};

/// Reads @p dir. False with *error naming the file and what is wrong ("<dir>/params.json: line 3,
/// column 7: expected ':'", "<dir>/params.bin: 440 bytes, parameter_block.bytes says 448", a
/// missing member or file); nothing partial is used then.
bool loadExport(const std::string& dir, ExportFolder& out, std::string* error);

/// The member @p name of type @p type, or null with *error when the export has no such member.
const Member* findMember(const ExportFolder& e, const std::string& name, const std::string& type,
                         std::string* error);

/// A whole decimal count in [lo, hi] (no trailing characters): false otherwise. For the
/// command-line options of both runners.
bool parseCount(const char* text, int lo, int hi, int* out);

} // namespace viewer
