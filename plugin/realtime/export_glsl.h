/// @file export_glsl.h
/// @brief `nimbus export-glsl`: a frame's march shader for engines, self-contained, with only
/// the features the frame uses in its text, its parameter block as raw std430 bytes and a JSON
/// description of the block (name, GLSL type, std430 offset, value, meaning, units of every
/// member), the bindings, the workgroup size and the dispatch (docs/realtime.md, "Export for
/// engines").
///
/// The shader is the one `nimbus rt` compiles (rt::marchShader, the same assembly code) with the
/// `#if` blocks of the RT_* feature macros preprocessed away: a disabled feature's code is not in
/// the text at all (no shadow march without a sun), an enabled one's has no `#if` around it; then
/// the functions and declarations nothing reaches from main() are removed (removeUnreferenced:
/// without a sun the octave and in-scatter kernels go too, and the kernels of other fields).
/// Every other preprocessor line is left for the engine's compiler; `#line` directives are
/// re-emitted after every removed line, so compiler messages keep the line numbers of the pass
/// and kernel files (the shader's header lists the source-string numbers).
///
/// @code
///   rt::GlslExport e;
///   std::string error;
///   if (!rt::exportGlsl(scene, plan, "scene.toml", e, &error)) ...   // unsupported or bad text
///   // e.shader -> march.comp, e.json -> params.json, e.params -> params.bin
/// @endcode
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/plan.h"
#include "core/scene.h"
#include "plugin/realtime/rt_march.h"

namespace nimbus::rt {

/// The RT_* feature macros of `features` and their values (RT_SUN, RT_AMBIENT,
/// RT_BACKGROUND_SKY, RT_MULTISAMPLE, RT_MIE_TABLE, RT_MS_DIFFUSION, RT_MS_PHOTONS,
/// RT_PHOTON_SKIN, RT_VDB, RT_BAKED_NOISE, RT_RGBA_NOISE, RT_SKIP, RT_SDF, RT_LIGHT_VOLUME,
/// RT_FORWARD_DELTA, RT_RESUMABLE).
std::vector<std::pair<std::string, bool>> featureMacros(const MarchFeatures& features);

/// Preprocesses the conditionals on the given macros out of GLSL `text`: `#if`, `#ifdef`,
/// `#ifndef`, `#elif`, `#else`, `#endif` whose condition names only these macros (with `!`,
/// `&&`, `||`, `==`, `!=`, parentheses, integers and `defined`) are evaluated; the lines of a
/// false branch and the directives themselves are removed. Conditionals on other names are kept
/// as they are (those inside a removed branch go with it). After removed lines a
/// `#line <n> <source>` keeps the numbering of what follows. False with *error (the line number
/// and why) on a condition that mixes these macros with other names, an `#elif`/`#else`/`#endif`
/// without its `#if`, or an `#if` without its `#endif`.
bool stripFeatureConditionals(std::string_view text,
                              const std::vector<std::pair<std::string, bool>>& macros,
                              std::string& out, std::string* error);

/// Removes from GLSL `text` the top-level functions, structs, constants and globals that main()
/// does not reach, directly or through others (a name counts as reached when it appears as a
/// word in the code of a kept item, comments left out): the kernels of other fields, the
/// lighting of a disabled feature. An item's comment lines above it go with it. Preprocessor
/// lines, `layout` declarations and main() are always kept; `#line` directives keep the
/// numbering after removed items, as stripFeatureConditionals does. Expects the kernels' form
/// (top-level items start on a line of their own; a function's body opens after its `)`).
/// False with *error on unbalanced braces or no main().
bool removeUnreferenced(std::string_view text, std::string& out, std::string* error);

/// One member of the parameter block (struct RtMarchParams, plugin/realtime/march_params.glsl)
/// as std430 lays it out.
struct ParamMember {
    std::string name;       ///< e.g. "camOrigin"
    std::string type;       ///< "vec4", "float", "int" or "uint"
    std::size_t offset = 0; ///< std430 byte offset in the block
    std::size_t size = 0;   ///< bytes
};

/// The block's members in order, read from the embedded text of march_params.glsl and laid out
/// by the std430 rules (vec4: 16-byte aligned, 16 bytes; scalars: 4 and 4); *blockSize gets the
/// block's std430 size (rounded up to its 16-byte alignment). False with *error on a member type
/// the rules here do not cover.
bool paramBlockLayout(std::vector<ParamMember>& members, std::size_t* blockSize,
                      std::string* error);

/// What a member means and its units, for the JSON; empty strings for an unknown name.
struct ParamDoc {
    std::string meaning;
    std::string units;
};
ParamDoc paramDoc(std::string_view name);

/// One export: the texts and bytes of the files `nimbus export-glsl` writes.
struct GlslExport {
    MarchFeatures features;
    std::string shader;               ///< march.comp
    std::string json;                 ///< params.json
    std::vector<std::uint8_t> params; ///< params.bin: the block, std430, for the frame
    /// The data buffers the shader reads, (file name, bytes): mie_table.bin (RT_MIE_TABLE),
    /// diffusion.bin (RT_MS_DIFFUSION), photons.bin (RT_MS_PHOTONS), skin_tau.bin
    /// (RT_PHOTON_SKIN), vdb_grid.bin (RT_VDB: the field's NanoVDB grid, vdbGridBytes),
    /// noise_base.bin and noise_detail.bin (RT_BAKED_NOISE: the CPU's baked noise tiles, res^3
    /// floats each, x fastest), majorant.bin (RT_SKIP: the frame's majorant grid, one float per
    /// cell, x fastest); their bindings and layouts are in params.json's "buffers". With
    /// RT_RGBA_NOISE the tiles are noise_base_rgba.bin and noise_detail_rgba.bin instead (RGBA8
    /// 3D textures, res^3 x 4 bytes), described in params.json's "textures".
    std::vector<std::pair<std::string, std::vector<std::uint8_t>>> data;
};

/// The names of the files in the output folder.
inline constexpr const char* kExportShaderFile = "march.comp";
inline constexpr const char* kExportJsonFile = "params.json";
inline constexpr const char* kExportParamsFile = "params.bin";
inline constexpr const char* kBaseChannelsFile = "noise_base_rgba.bin";
inline constexpr const char* kDetailChannelsFile = "noise_detail_rgba.bin";

/// Exports frame `plan` of `scene` (`scenePath` is recorded in the JSON; `bindings`: what the
/// host bound to the frame, which a VDB field's grid comes from). False with *error when
/// the frame is unsupported (the first unsupported() message; the caller checks and names every
/// key first), or when the shader or the block cannot be processed. `noise`: the tiles the CPU
/// baked (bakedNoise), which a frame whose plan bakes the cumulus noise needs (bakedNoiseError).
/// `majorant`: the frame's majorant grid (majorantGrid); where the pass skips with it
/// (skipsWith) the shader has RT_SKIP and the grid goes out as majorant.bin.
bool exportGlsl(const SceneDesc& scene, const FramePlan& plan, const std::string& scenePath,
                const MarchGrids* grids, const FrameBindings* bindings, const BakedNoise* noise,
                const MajorantGrid* majorant, GlslExport& out, std::string* error);
/// The same without a majorant grid (no empty-space skipping).
inline bool exportGlsl(const SceneDesc& scene, const FramePlan& plan, const std::string& scenePath,
                       const MarchGrids* grids, const FrameBindings* bindings,
                       const BakedNoise* noise, GlslExport& out, std::string* error) {
    return exportGlsl(scene, plan, scenePath, grids, bindings, noise, nullptr, out, error);
}
/// The same for a frame whose plan does not bake the noise.
inline bool exportGlsl(const SceneDesc& scene, const FramePlan& plan, const std::string& scenePath,
                       const MarchGrids* grids, const FrameBindings* bindings, GlslExport& out,
                       std::string* error) {
    return exportGlsl(scene, plan, scenePath, grids, bindings, nullptr, out, error);
}
/// The same for a frame with nothing bound (no VDB field).
inline bool exportGlsl(const SceneDesc& scene, const FramePlan& plan, const std::string& scenePath,
                       const MarchGrids* grids, GlslExport& out, std::string* error) {
    return exportGlsl(scene, plan, scenePath, grids, nullptr, out, error);
}
/// The same for a frame without multiple-scattering grids.
inline bool exportGlsl(const SceneDesc& scene, const FramePlan& plan, const std::string& scenePath,
                       GlslExport& out, std::string* error) {
    return exportGlsl(scene, plan, scenePath, nullptr, out, error);
}

} // namespace nimbus::rt
