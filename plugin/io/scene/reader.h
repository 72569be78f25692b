/// @file reader.h
/// @brief Reading a TOML document against the parameter table (table.h): problems with their
///        locations, `--set` overrides, validation of sections and [[array]] tables, and the
///        rules across keys (rules.cpp). Internal to plugin/io.
#pragma once

#include <functional>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

/// The source name and the override labels, to turn a TOML node into a Where.
struct Context {
    std::string sourceName;
    std::vector<std::string> labels; ///< "--set section.key=value", one per override

    Where at(const toml::source_region& r) const;
    Where at(const toml::node& n) const { return at(n.source()); }
    /// For unknown keys: the key itself in the file, or the override that introduced it.
    Where atKey(const toml::key& k, const toml::node& n) const;
};

/// Every problem found, reported at once.
struct Problems {
    std::vector<std::pair<Where, std::string>> items;

    void add(Where w, std::string text) { items.emplace_back(std::move(w), std::move(text)); }
    bool empty() const { return items.empty(); }

    /// All problems, one per line, in file order then override order.
    std::vector<std::string> lines(std::string_view tag = "");
    [[noreturn]] void raise();
};

/// What a node holds, for "found ..." in messages.
std::string describe(const toml::node& n);

/// Reads @p n as the value of row @p p; adds a problem and returns nullopt when it is not.
std::optional<Value> read(const Param& p, const toml::node& n, const Context& cx, Problems& pr);

/// Parses one `section.key=value` override and merges it into @p root.
void applyOverride(toml::table& root, const std::string& label, const std::string& override);

/// Checks every key of @p root against the registry and fills @p s.
void validate(const toml::table& root, Staging& s, const Context& cx, Problems& pr);
/// Reads the [[array]] tables of @p root.
void validateArrays(const toml::table& root, Staging& s, const Context& cx, Problems& pr);
/// Reads the tables inside [field] that belong to its kind ([[field.ellipsoid]], ...).
void validateFieldSubTables(const toml::table& root, Staging& s, const Context& cx, Problems& pr);
/// Required keys, names, scatter expansion and the default placements.
void resolveArrays(Staging& s, Problems& pr);
/// Keys given although their value is ignored (e.g. medium.g with an isotropic phase).
std::vector<std::string> ignoredKeyWarnings(const Staging& s);

/// A rule across keys, with its one-line doc for the reference.
struct Rule {
    std::string section;
    std::string doc;
    std::function<void(Staging&, const Context&, Problems&)> apply;
};

const std::vector<Rule>& rules();

} // namespace nimbus::io::scene
