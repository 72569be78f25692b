/// @file params_sdf.cpp
/// @brief Scene-file SDF trees: the rows of one node table and the reading of an array of node
///        tables into an SdfNodeDesc tree (see params_sdf.h), and the [field] rows of
///        kind = "sdf".
#include "plugin/io/scene/params_sdf.h"

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>

namespace nimbus::io::scene {

namespace {

using Row = Staging::SdfNodeRow;

const WordTable<SdfKind> kSdfKinds = {{"sphere", SdfKind::Sphere},
                                      {"ellipsoid", SdfKind::Ellipsoid},
                                      {"box", SdfKind::Box},
                                      {"round_box", SdfKind::RoundBox},
                                      {"capsule", SdfKind::Capsule},
                                      {"torus", SdfKind::Torus},
                                      {"cone", SdfKind::Cone},
                                      {"plane", SdfKind::Plane},
                                      {"union", SdfKind::Union},
                                      {"intersection", SdfKind::Intersection},
                                      {"subtraction", SdfKind::Subtraction}};

const WordTable<SdfNoise> kSdfNoises = {{"perlin", SdfNoise::Perlin}, {"worley", SdfNoise::Worley}};

/// Keys every node takes.
const std::vector<std::string> kCommonKeys = {"type",      "name",    "parent",   "translate",
                                              "rotate",    "scale",   "displace", "noise",
                                              "frequency", "octaves", "gain",     "seed"};

/// The keys of each type beyond the common ones.
std::vector<std::string> typeKeys(SdfKind k) {
    switch (k) {
    case SdfKind::Sphere:
        return {"radius"};
    case SdfKind::Ellipsoid:
        return {"radii"};
    case SdfKind::Box:
        return {"size"};
    case SdfKind::RoundBox:
        return {"size", "rounding"};
    case SdfKind::Capsule:
        return {"a", "b", "radius"};
    case SdfKind::Torus:
        return {"major_radius", "minor_radius"};
    case SdfKind::Cone:
        return {"radius", "height"};
    case SdfKind::Plane:
        return {"normal", "offset"};
    default:
        return {"smooth"};
    }
}

/// The node's own parameters, checked as a tree of one node ("" when fine).
std::string checkNode(const SdfNodeDesc& d) {
    SdfNodeDesc alone = d;
    alone.children.clear();
    if (!sdfIsPrimitive(d.kind)) alone.children.push_back(sdfSphere(1.0f));
    try {
        flattenSdf(alone);
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

} // namespace

const std::vector<Param>& sdfNodeRegistry() {
    static const std::vector<Param> table = [] {
        const Section<Row> n{"node", [](Staging& s) -> Row& { return s.sdfNodes[s.element]; }};
        std::vector<Param> t;
        t.push_back(n.param("type", kSdfKinds,
                            "Required. A primitive (sphere ... plane) or an operator (union, "
                            "intersection, subtraction: the first child minus the others).",
                            &Row::desc, &SdfNodeDesc::kind));
        t.push_back(
            n.param("name", {}, "Name the children of an operator give as `parent`.", &Row::name)
                .checkedBy(nonEmpty));
        t.push_back(n.param("parent", {},
                            "The `name` of the operator this node belongs to; none: top level.",
                            &Row::parent)
                        .checkedBy(nonEmpty));
        t.push_back(n.param("radius", above(0),
                            "sphere: radius; capsule: radius around the segment; cone: radius "
                            "of the base disc (at y = 0).",
                            &Row::desc, &SdfNodeDesc::radius));
        t.push_back(n.param("radii", above(0),
                            "ellipsoid: semi-axes along x, y, z (its distance is a bound, never "
                            "more than the true distance).",
                            &Row::desc, &SdfNodeDesc::radii));
        t.push_back(n.param("size", above(0), "box, round_box: half-extents along x, y, z.",
                            &Row::desc, &SdfNodeDesc::size));
        t.push_back(n.param("rounding", atLeast(0),
                            "round_box: edge radius, at most the smallest half-extent (the "
                            "outer size stays `size`).",
                            &Row::desc, &SdfNodeDesc::rounding));
        t.push_back(
            n.param("a", {}, "capsule: one end of the segment.", &Row::desc, &SdfNodeDesc::a));
        t.push_back(n.param("b", {}, "capsule: the other end.", &Row::desc, &SdfNodeDesc::b));
        t.push_back(n.param("major_radius", above(0),
                            "torus: radius of the ring (in the xz plane, about y).", &Row::desc,
                            &SdfNodeDesc::majorRadius));
        t.push_back(n.param("minor_radius", above(0),
                            "torus: radius of the tube, at most major_radius.", &Row::desc,
                            &SdfNodeDesc::minorRadius));
        t.push_back(n.param("height", above(0), "cone: height of the apex above the base.",
                            &Row::desc, &SdfNodeDesc::height));
        t.push_back(n.param("normal", {},
                            "plane: normal (normalised); the solid is the side it points away "
                            "from.",
                            &Row::desc, &SdfNodeDesc::normal)
                        .checkedBy(nonZero));
        t.push_back(n.param("offset", {}, "plane: dot(p, normal) = offset on the plane.",
                            &Row::desc, &SdfNodeDesc::offset));
        t.push_back(n.param("smooth", atLeast(0),
                            "Operators: blend width k of the polynomial smooth min/max "
                            "(lowers a union by at most k/4); 0: hard.",
                            &Row::desc, &SdfNodeDesc::smooth));
        t.push_back(n.param("translate", {}, "Translation (parent units).", &Row::desc,
                            &SdfNodeDesc::transform, &SdfTransform::translate));
        t.push_back(n.param("rotate", {}, "Rotation in degrees about x, then y, then z.",
                            &Row::desc, &SdfNodeDesc::transform, &SdfTransform::rotate));
        t.push_back(n.param("scale", above(0),
                            "Scale along x, y, z; a non-uniform scale multiplies the distance "
                            "by its smallest component (a bound).",
                            &Row::desc, &SdfNodeDesc::transform, &SdfTransform::scale));
        t.push_back(n.param("displace", atLeast(0),
                            "Noise displacement amplitude A (node units): distance + A n, n in "
                            "[-1, 1]; 0: none.",
                            &Row::desc, &SdfNodeDesc::displacement, &SdfDisplacement::amplitude));
        t.push_back(n.param("noise", kSdfNoises,
                            "Displacement noise: Perlin fBm, or Worley fBm as 1 - 2 w (billows).",
                            &Row::desc, &SdfNodeDesc::displacement, &SdfDisplacement::noise));
        t.push_back(n.param("frequency", above(0), "Noise cells per node unit.", &Row::desc,
                            &SdfNodeDesc::displacement, &SdfDisplacement::frequency));
        t.push_back(n.param("octaves", closed(1, 12), "Octaves of the noise's fBm.", &Row::desc,
                            &SdfNodeDesc::displacement, &SdfDisplacement::octaves));
        t.push_back(n.param("gain", openClosed(0, 1), "Amplitude ratio of successive octaves.",
                            &Row::desc, &SdfNodeDesc::displacement, &SdfDisplacement::gain));
        t.push_back(n.param("seed", kUInt32, "Seed of the noise.", &Row::desc,
                            &SdfNodeDesc::displacement, &SdfDisplacement::seed));
        return t;
    }();
    return table;
}

void addSdfFieldParams(std::vector<Param>& t) {
    const Section<SdfFieldDesc> sd{
        "field", [](Staging& s) -> SdfFieldDesc& { return s.file.scene.field.sdf; },
        FieldKind::Sdf};
    t.push_back(sd.param("density", atLeast(0),
                         "Density deeper inside the SDF surface than `falloff`.",
                         &SdfFieldDesc::density));
    t.push_back(sd.param("falloff", atLeast(0),
                         "Width of the soft edge inside the surface: density = density * "
                         "smoothstep(0, falloff, -d), d the (displaced) signed distance of the "
                         "[[field.node]] tree; 0: a hard edge.",
                         &SdfFieldDesc::falloff));
}

std::optional<SdfNodeDesc> readSdfTree(const toml::node& array, const std::string& label,
                                       const Context& cx, Problems& pr) {
    const size_t before = pr.items.size();
    const toml::array* arr = array.as_array();
    if (!arr || !arr->is_array_of_tables() || arr->empty()) {
        pr.add(cx.at(array),
               label + ": expected one or more [[" + label + "]] tables, found " + describe(array));
        return std::nullopt;
    }
    std::vector<std::string> keys;
    for (const Param& p : sdfNodeRegistry()) keys.push_back(p.key);
    Staging s;
    std::vector<char> typeWritten(arr->size(), 0); // a `type` key, read or not
    for (size_t i = 0; i < arr->size(); ++i) {
        const toml::table& tbl = *arr->get(i)->as_table();
        s.sdfNodes.push_back(Row{});
        s.sdfNodes.back().where = cx.at(tbl);
        s.element = i;
        const std::string element = label + "[" + std::to_string(i) + "]";
        for (auto&& [k, node] : tbl) {
            const std::string key(k.str());
            if (key == "type") typeWritten[i] = 1;
            const Param* p = nullptr;
            for (const Param& q : sdfNodeRegistry())
                if (q.key == key) p = &q;
            if (!p) {
                pr.add(cx.atKey(k, node), "unknown key " + quote(element + "." + key) +
                                              suggestion(key, keys) + "; [[" + label +
                                              "]] accepts " + join(keys, ", "));
                continue;
            }
            Param named = *p;
            named.section = element;
            if (std::optional<Value> v = read(named, node, cx, pr)) {
                p->set(s, *v);
                s.sdfNodes.back().given[key] = cx.atKey(k, node);
            }
        }
    }
    // types, the keys each type takes, names (a `type` that did not read is reported already)
    std::map<std::string, size_t> byName;
    for (size_t i = 0; i < s.sdfNodes.size(); ++i) {
        Row& r = s.sdfNodes[i];
        const std::string element = label + "[" + std::to_string(i) + "]";
        if (!r.given.count("type")) {
            if (typeWritten[i]) continue;
            pr.add(r.where, element + ": `type` is required (one of " + quotedList([] {
                                std::vector<std::string> w;
                                for (const auto& [name, k] : kSdfKinds) w.push_back(name);
                                return w;
                            }()) +
                                ")");
            continue;
        }
        std::vector<std::string> allowed = kCommonKeys;
        const std::vector<std::string> own = typeKeys(r.desc.kind);
        allowed.insert(allowed.end(), own.begin(), own.end());
        for (const auto& [key, where] : r.given)
            if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
                pr.add(where, element + "." + key + ": a " + sdfKindName(r.desc.kind) +
                                  " does not take `" + key + "`; it takes " + join(own, ", "));
        if (!r.name.empty() && !byName.emplace(r.name, i).second)
            pr.add(r.given["name"], element + ".name: " + quote(r.name) +
                                        " is already the name of " + label + "[" +
                                        std::to_string(byName[r.name]) + "]");
        const std::string problem = checkNode(r.desc);
        if (!problem.empty()) pr.add(r.where, element + ": " + problem);
    }
    if (pr.items.size() != before) return std::nullopt;

    // parents: known operators, no cycles
    std::vector<int> parent(s.sdfNodes.size(), -1);
    for (size_t i = 0; i < s.sdfNodes.size(); ++i) {
        Row& r = s.sdfNodes[i];
        if (r.parent.empty()) continue;
        const std::string element = label + "[" + std::to_string(i) + "]";
        auto it = byName.find(r.parent);
        if (it == byName.end()) {
            std::vector<std::string> names;
            for (const auto& [name, j] : byName) names.push_back(name);
            pr.add(r.given["parent"], element + ".parent: no node is named " + quote(r.parent) +
                                          suggestion(r.parent, names));
            continue;
        }
        if (sdfIsPrimitive(s.sdfNodes[it->second].desc.kind)) {
            pr.add(r.given["parent"], element + ".parent: " + quote(r.parent) + " is a " +
                                          sdfKindName(s.sdfNodes[it->second].desc.kind) +
                                          ", not an operator (union, intersection, subtraction)");
            continue;
        }
        parent[i] = int(it->second);
    }
    if (pr.items.size() != before) return std::nullopt;
    for (size_t i = 0; i < parent.size(); ++i) {
        size_t steps = 0;
        for (int j = int(i); j >= 0 && steps <= parent.size(); j = parent[size_t(j)]) ++steps;
        if (steps > parent.size()) {
            pr.add(s.sdfNodes[i].given["parent"], label + "[" + std::to_string(i) +
                                                      "].parent: " + quote(s.sdfNodes[i].parent) +
                                                      " is inside this node (a cycle)");
            return std::nullopt;
        }
    }
    std::vector<std::vector<size_t>> children(parent.size());
    std::vector<size_t> top;
    for (size_t i = 0; i < parent.size(); ++i)
        (parent[i] < 0 ? top : children[size_t(parent[i])]).push_back(i);
    for (size_t i = 0; i < parent.size(); ++i)
        if (!sdfIsPrimitive(s.sdfNodes[i].desc.kind) && children[i].empty())
            pr.add(s.sdfNodes[i].where,
                   label + "[" + std::to_string(i) + "]: the " +
                       sdfKindName(s.sdfNodes[i].desc.kind) + " " + quote(s.sdfNodes[i].name) +
                       " has no children (nodes with parent = " + quote(s.sdfNodes[i].name) + ")");
    if (pr.items.size() != before) return std::nullopt;

    // the tree, children in file order (no recursion: parents after their children)
    std::vector<SdfNodeDesc> built(parent.size());
    std::vector<int> depth(parent.size(), 0);
    std::vector<char> done(parent.size(), 0);
    for (size_t pass = 0, left = parent.size(); left > 0 && pass <= parent.size(); ++pass)
        for (size_t i = 0; i < parent.size(); ++i) {
            if (done[i]) continue;
            bool ready = true;
            for (size_t c : children[i]) ready = ready && done[c];
            if (!ready) continue;
            built[i] = s.sdfNodes[i].desc;
            for (size_t c : children[i]) {
                depth[i] = std::max(depth[i], depth[c] + 1);
                built[i].children.push_back(std::move(built[c]));
            }
            done[i] = 1;
            --left;
        }
    SdfNodeDesc root;
    if (top.size() == 1) {
        root = std::move(built[top[0]]);
    } else {
        root.kind = SdfKind::Union;
        for (size_t i : top) root.children.push_back(std::move(built[i]));
    }
    try {
        flattenSdf(root);
    } catch (const std::invalid_argument& e) {
        pr.add(s.sdfNodes[top[0]].where, label + ": " + e.what());
        return std::nullopt;
    }
    return root;
}

void readSdfField(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    const toml::table* field = root["field"].as_table();
    const toml::node* nodes = field ? field->get("node") : nullptr;
    if (!nodes) {
        const auto kind = s.given.find("field.kind");
        pr.add(kind != s.given.end() ? kind->second : Where{cx.sourceName, 0, 0, 0},
               "field.kind = \"sdf\" needs its tree: one or more [[field.node]] tables "
               "(see the reference)");
        return;
    }
    std::optional<SdfNodeDesc> tree = readSdfTree(*nodes, "field.node", cx, pr);
    if (!tree) return;
    if (!sdfBoxBounded(flattenSdf(*tree).supportBox(0.0f))) {
        pr.add(cx.at(*nodes), "field.node: the cloud is unbounded (a plane that no "
                              "intersection with a bounded node closes); intersect it with a "
                              "box");
        return;
    }
    s.file.scene.field.sdf.root = std::move(*tree);
}

} // namespace nimbus::io::scene
