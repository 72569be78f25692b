/// @file export_folder.cpp
/// @brief Reads an export folder (see export_folder.h): params.json through nlohmann::json
///        (errors with line and column) and the fields of it the viewer uses.
#include "export_folder.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace viewer {
namespace {

// --- JSON: nlohmann::json parses; a plain tree of the values is what the code below reads ------

struct Json {
    enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
    bool b = false;
    double number = 0.0;
    std::string text; // a string's value
    std::vector<Json> items;
    std::vector<std::pair<std::string, Json>> members;

    const Json* find(const std::string& key) const {
        for (const auto& m : members)
            if (m.first == key) return &m.second;
        return nullptr;
    }
};

struct JsonError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

Json fromNlohmann(const nlohmann::json& j) {
    Json v;
    if (j.is_object()) {
        v.kind = Json::Object;
        for (const auto& [key, value] : j.items()) v.members.emplace_back(key, fromNlohmann(value));
    } else if (j.is_array()) {
        v.kind = Json::Array;
        for (const nlohmann::json& x : j) v.items.push_back(fromNlohmann(x));
    } else if (j.is_string()) {
        v.kind = Json::String;
        v.text = j.get<std::string>();
    } else if (j.is_boolean()) {
        v.kind = Json::Bool;
        v.b = j.get<bool>();
    } else if (j.is_number()) {
        v.kind = Json::Number;
        v.number = j.get<double>();
    }
    return v;
}

/// @p text parsed; JsonError with nlohmann's message (line, column and what was expected).
Json parseJson(const std::string& text) {
    try {
        return fromNlohmann(nlohmann::json::parse(text));
    } catch (const nlohmann::json::parse_error& e) {
        std::string what = e.what();
        const std::size_t at = what.find("parse error at "); // drop "[json.exception...] "
        throw JsonError(at == std::string::npos ? what : what.substr(at + 15));
    }
}

// --- typed access with errors naming the path in the document ---------------------------------

struct FieldError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

const Json& field(const Json& v, const std::string& key, Json::Kind kind, const std::string& path) {
    static const char* kNames[] = {"null",     "a boolean", "a number",
                                   "a string", "an array",  "an object"};
    const Json* f = v.kind == Json::Object ? v.find(key) : nullptr;
    if (!f) throw FieldError("no \"" + path + key + "\"");
    if (f->kind != kind)
        throw FieldError("\"" + path + key + "\" is not " + std::string(kNames[kind]));
    return *f;
}

/// A non-negative whole number (offsets, sizes, bindings, counts); @p what names it in errors.
std::size_t whole(const Json& v, const std::string& what) {
    const double x = v.kind == Json::Number ? v.number : -1.0;
    if (!(x >= 0.0) || x > 1e15 || x != double(std::size_t(x)))
        throw FieldError("\"" + what + "\" is not a whole number >= 0");
    return std::size_t(x);
}

std::size_t count(const Json& v, const std::string& key, const std::string& path) {
    return whole(field(v, key, Json::Number, path), path + key);
}

bool readFile(const std::string& path, std::string& out, std::string* error) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        if (error) *error = path + ": cannot open (" + std::strerror(errno) + ")";
        return false;
    }
    std::ostringstream s;
    s << in.rdbuf();
    out = s.str();
    return true;
}

} // namespace

bool loadExport(const std::string& dir, ExportFolder& out, std::string* error) {
    const std::string jsonPath = dir + "/params.json";
    std::string text;
    if (!readFile(jsonPath, text, error)) return false;
    Json doc;
    try {
        doc = parseJson(text);
    } catch (const JsonError& e) {
        if (error) *error = jsonPath + ": " + e.what();
        return false;
    }

    ExportFolder e;
    std::string shaderFile, paramsFile;
    try {
        const Json& format = field(doc, "format", Json::String, "");
        if (format.text != "nimbus-export-glsl")
            throw FieldError("\"format\" is \"" + format.text + "\", not \"nimbus-export-glsl\"");
        if (count(doc, "format_version", "") != 1)
            throw FieldError("\"format_version\" is not 1 (this viewer reads version 1)");
        shaderFile = field(doc, "shader", Json::String, "").text;

        const Json& image = field(doc, "image", Json::Object, "");
        e.width = int(count(image, "width", "image."));
        e.height = int(count(image, "height", "image."));
        if (e.width < 1 || e.height < 1) throw FieldError("\"image\" is empty");

        const Json& dispatch = field(doc, "dispatch", Json::Object, "");
        const Json& groups = field(dispatch, "groups", Json::Array, "dispatch.");
        if (groups.items.size() != 3) throw FieldError("\"dispatch.groups\" is not 3 numbers");
        for (int k = 0; k < 3; ++k)
            e.groups[k] = unsigned(whole(groups.items[std::size_t(k)], "dispatch.groups"));
        e.passes = int(count(dispatch, "passes", "dispatch."));
        if (e.passes < 1) throw FieldError("\"dispatch.passes\" is 0");

        const Json& block = field(doc, "parameter_block", Json::Object, "");
        e.paramBinding = unsigned(count(block, "binding", "parameter_block."));
        const std::size_t blockBytes = count(block, "bytes", "parameter_block.");
        paramsFile = field(block, "file", Json::String, "parameter_block.").text;
        for (const Json& m : field(block, "members", Json::Array, "parameter_block.").items) {
            const std::string at = "parameter_block.members[].";
            Member mb;
            mb.type = field(m, "type", Json::String, at).text;
            mb.offset = count(m, "offset", at);
            const std::size_t size = mb.type == "vec4" ? 16 : 4;
            if (mb.offset + size > blockBytes)
                throw FieldError("member \"" + field(m, "name", Json::String, at).text +
                                 "\" lies past parameter_block.bytes");
            e.members[field(m, "name", Json::String, at).text] = mb;
        }

        for (const Json& b : field(doc, "buffers", Json::Array, "").items) {
            WorkBuffer w;
            w.binding = unsigned(count(b, "binding", "buffers[]."));
            w.block = field(b, "block", Json::String, "buffers[].").text;
            w.bytes = count(b, "bytes", "buffers[].");
            if (w.binding == e.paramBinding) continue; // the parameter block
            if (w.bytes == 0) throw FieldError("buffer \"" + w.block + "\" has 0 bytes");
            if (const Json* file = b.find("file")) {
                // a data buffer (Mie table, multiple-scattering grid): its file, of its size
                if (file->kind != Json::String)
                    throw FieldError("buffers[].file of \"" + w.block + "\" is not a string");
                std::string bytes;
                if (!readFile(dir + "/" + file->text, bytes, error)) return false;
                if (bytes.size() != w.bytes) {
                    if (error)
                        *error = dir + "/" + file->text + ": " + std::to_string(bytes.size()) +
                                 " bytes, buffers[].bytes of \"" + w.block + "\" says " +
                                 std::to_string(w.bytes);
                    return false;
                }
                w.data.assign(bytes.begin(), bytes.end());
            }
            e.buffers.push_back(w);
        }

        for (const Json& t : field(doc, "textures", Json::Array, "").items) {
            TextureFile tf;
            tf.unit = unsigned(count(t, "unit", "textures[]."));
            const std::string& file = field(t, "file", Json::String, "textures[].").text;
            if (field(t, "format", Json::String, "textures[].").text != "GL_RGBA8" ||
                field(t, "target", Json::String, "textures[].").text != "GL_TEXTURE_3D")
                throw FieldError("texture " + file + " is not a GL_RGBA8 GL_TEXTURE_3D");
            const Json& size = field(t, "size", Json::Array, "textures[].");
            if (size.items.size() != 3)
                throw FieldError("texture " + file + ": size is not [x, y, z]");
            std::size_t texels = 1;
            for (int k = 0; k < 3; ++k) {
                const Json& v = size.items[std::size_t(k)];
                if (v.kind != Json::Number || !(v.number >= 1.0 && v.number <= 4096.0) ||
                    v.number != double(int(v.number)))
                    throw FieldError("texture " + file + ": size[" + std::to_string(k) +
                                     "] is not a whole number in [1, 4096]");
                tf.size[k] = int(v.number);
                texels *= std::size_t(tf.size[k]);
            }
            std::string bytes;
            if (!readFile(dir + "/" + file, bytes, error)) return false;
            if (bytes.size() != 4 * texels) {
                if (error)
                    *error = dir + "/" + file + ": " + std::to_string(bytes.size()) +
                             " bytes, textures[].size says " + std::to_string(4 * texels);
                return false;
            }
            tf.data.assign(bytes.begin(), bytes.end());
            e.textures.push_back(std::move(tf));
        }

        const Json& output = field(doc, "output", Json::Object, "");
        e.outputBinding = unsigned(count(output, "buffer_binding", "output."));
        e.floatsPerPixel = int(count(output, "floats_per_pixel", "output."));
        const Json& floats = field(output, "floats", Json::Array, "output.");
        const char* rgba[4] = {"sum w*R", "sum w*G", "sum w*B", "sum w*alpha"};
        for (std::size_t k = 0; k < floats.items.size(); ++k) {
            if (floats.items[k].kind != Json::String) continue;
            for (int c = 0; c < 4; ++c)
                if (floats.items[k].text == rgba[c]) e.rgbaIndex[c] = int(k);
            if (floats.items[k].text == "sum w") e.weightIndex = int(k);
        }
        for (int c = 0; c < 4; ++c)
            if (e.rgbaIndex[c] < 0)
                throw FieldError("\"output.floats\" has no \"" + std::string(rgba[c]) + "\"");
        if (e.weightIndex < 0) throw FieldError("\"output.floats\" has no \"sum w\"");
        bool found = false;
        for (const WorkBuffer& w : e.buffers) {
            if (w.binding != e.outputBinding) continue;
            found = true;
            const std::size_t need =
                std::size_t(e.width) * std::size_t(e.height) * std::size_t(e.floatsPerPixel) * 4;
            if (w.bytes != need)
                throw FieldError("the output buffer has " + std::to_string(w.bytes) +
                                 " bytes, image and floats_per_pixel need " + std::to_string(need));
        }
        if (!found) throw FieldError("no buffer at output.buffer_binding");

        if (!readFile(dir + "/" + paramsFile, text, error)) return false;
        if (text.size() != blockBytes) {
            if (error)
                *error = dir + "/" + paramsFile + ": " + std::to_string(text.size()) +
                         " bytes, parameter_block.bytes says " + std::to_string(blockBytes);
            return false;
        }
        e.params.assign(text.begin(), text.end());
    } catch (const FieldError& f) {
        if (error) *error = jsonPath + ": " + f.what();
        return false;
    }
    if (!readFile(dir + "/" + shaderFile, e.shader, error)) return false;
    out = std::move(e);
    return true;
}

const Member* findMember(const ExportFolder& e, const std::string& name, const std::string& type,
                         std::string* error) {
    const auto it = e.members.find(name);
    if (it == e.members.end() || it->second.type != type) {
        if (error)
            *error = "params.json: the parameter block has no " + type + " member \"" + name + "\"";
        return nullptr;
    }
    return &it->second;
}

bool parseCount(const char* text, int lo, int hi, int* out) {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno == ERANGE || v < lo || v > hi) return false;
    *out = int(v);
    return true;
}

} // namespace viewer
