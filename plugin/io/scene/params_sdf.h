/// @file params_sdf.h
/// @brief Reading a tree of SDF nodes from an array of TOML tables (`[[field.node]]`; any other
///        array of node tables works the same way), with file:line errors. Internal to plugin/io.
///
/// A tree is a flat list of tables. Each table is one node: a primitive (`type = "sphere"`,
/// ...) or an operator (`type = "union"`, ...). A node names its operator with
/// `parent = "<name>"`; an operator is a node with a `name`. Children of an operator are taken
/// in file order (subtraction: the first child minus the others). Nodes without `parent` are the
/// top level: one is the root, several are combined by a hard union.
///
/// @code
///   // in a reader: the array under [field] (or [[solid]]) called "node"
///   if (const toml::node* n = table.get("node"))
///       if (std::optional<SdfNodeDesc> tree = readSdfTree(*n, "field.node", cx, pr))
///           desc.root = std::move(*tree);
/// @endcode
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/sdf/sdf.h"
#include "plugin/io/scene/reader.h"

namespace nimbus::io::scene {

/// The rows of one node table (section "node"): for the reference and for error messages.
const std::vector<Param>& sdfNodeRegistry();

/// Reads the node tables of @p array (labelled @p label in messages, e.g. "field.node") into
/// one tree. Every problem goes to @p pr with its file:line (unknown keys, keys the node's type
/// does not take, parameters out of range, names missing, repeated or unknown, operators
/// without children, cycles); returns nullopt when there was any.
std::optional<SdfNodeDesc> readSdfTree(const toml::node& array, const std::string& label,
                                       const Context& cx, Problems& pr);

/// [field] with kind = "sdf": reads its [[field.node]] tree into the staging (required) and
/// checks that the cloud is bounded.
void readSdfField(const toml::table& root, Staging& s, const Context& cx, Problems& pr);

} // namespace nimbus::io::scene
