// Reading SDF node trees from TOML (plugin/io/scene/params_sdf.h): the tree a file describes,
// and file:line errors for every kind of mistake.
#include <gtest/gtest.h>

#include <toml++/toml.h>

#include "plugin/io/scene/params_sdf.h"
#include "tests/test_util.h"

using namespace nimbus;
using namespace nimbus::io::scene;

namespace {

struct Read {
    std::optional<SdfNodeDesc> tree;
    std::string errors; ///< one per line
};

Read readTree(const std::string& text) {
    const toml::table root = toml::parse(text, std::string("t.toml"));
    Context cx{"t.toml", {}};
    Problems pr;
    Read r;
    const toml::node* n = root["field"]["node"].node();
    EXPECT_NE(n, nullptr);
    if (n) r.tree = readSdfTree(*n, "field.node", cx, pr);
    for (const std::string& l : pr.lines()) r.errors += l + "\n";
    EXPECT_EQ(r.tree.has_value(), r.errors.empty()) << r.errors;
    return r;
}

} // namespace

TEST(SdfSceneTree, ReadsNestedOperatorsInFileOrder) {
    const Read r = readTree(R"(
[[field.node]]
type = "sphere"
radius = 2.0
parent = "cut"

[[field.node]]
name = "cut"
type = "subtraction"
smooth = 0.25
translate = [1, 2, 3]

[[field.node]]
type = "box"
size = [0.5, 0.5, 3]
rotate = [0, 45, 0]
parent = "cut"
displace = 0.1
noise = "worley"
)");
    ASSERT_TRUE(r.tree);
    const SdfNodeDesc& root = *r.tree;
    EXPECT_EQ(root.kind, SdfKind::Subtraction);
    EXPECT_EQ(root.smooth, 0.25f);
    EXPECT_EQ(root.transform.translate, vec3(1, 2, 3));
    ASSERT_EQ(root.children.size(), 2u);
    EXPECT_EQ(root.children[0].kind, SdfKind::Sphere); // file order: sphere minus box
    EXPECT_EQ(root.children[0].radius, 2.0f);
    EXPECT_EQ(root.children[1].kind, SdfKind::Box);
    EXPECT_EQ(root.children[1].displacement.noise, SdfNoise::Worley);
    EXPECT_EQ(root.children[1].displacement.amplitude, 0.1f);
    // the tree it describes: inside the sphere (moved to (1,2,3)), outside the box slab
    const SdfTree t = flattenSdf(root);
    EXPECT_LT(t.bound(vec3(1, 2, 3) + vec3(0, 1.5f, 0)), 0.0f);
    EXPECT_GT(t.bound(vec3(1, 2, 3)), 0.0f); // the box is cut out of the centre
}

TEST(SdfSceneTree, SeveralTopLevelNodesAreAHardUnion) {
    const Read r = readTree(R"(
[[field.node]]
type = "sphere"
[[field.node]]
type = "torus"
major_radius = 2
minor_radius = 0.5
)");
    ASSERT_TRUE(r.tree);
    EXPECT_EQ(r.tree->kind, SdfKind::Union);
    EXPECT_EQ(r.tree->smooth, 0.0f);
    EXPECT_EQ(r.tree->children.size(), 2u);
}

TEST(SdfSceneTree, ReportsEveryMistakeWithItsLine) {
    // unknown key, wrong type, out of range, key of another type, missing type
    Read r = readTree(R"(
[[field.node]]
type = "sphere"
radiuss = 1
[[field.node]]
type = "box"
size = 2
[[field.node]]
type = "sphere"
radius = -1
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:4:1: unknown key \"field.node[0].radiuss\" (did you "
                                   "mean \"radius\"?)"));
    EXPECT_TRUE(contains(
        r.errors,
        "t.toml:7:8: field.node[1].size: expected an array of 3 numbers [x, y, z], each > 0, "
        "found 2"));
    EXPECT_TRUE(contains(r.errors, "t.toml:10:10: field.node[2].radius: expected a number > 0"));
    r = readTree(R"(
[[field.node]]
type = "box"
radius = 1
[[field.node]]
radius = 1
[[field.node]]
type = "cube"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:4:1: field.node[0].radius: a box does not take "
                                   "`radius`; it takes size"));
    EXPECT_TRUE(contains(r.errors, "t.toml:5:1: field.node[1]: `type` is required"));
    EXPECT_TRUE(contains(
        r.errors,
        "t.toml:8:8: field.node[2].type: unknown value \"cube\" (did you mean \"cone\"?)"));
    // parameters checked together, names, parents, cycles, childless operators
    r = readTree(R"(
[[field.node]]
type = "round_box"
size = [1, 1, 1]
rounding = 2
[[field.node]]
type = "union"
name = "u"
[[field.node]]
type = "sphere"
parent = "v"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:2:1: field.node[0]: round_box: rounding must be in"));
    r = readTree(R"(
[[field.node]]
type = "union"
name = "u"
[[field.node]]
type = "sphere"
parent = "v"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:7:1: field.node[1].parent: no node is named \"v\" (did "
                                   "you mean \"u\"?)"));
    r = readTree(R"(
[[field.node]]
type = "union"
name = "u"
parent = "w"
[[field.node]]
type = "union"
name = "w"
parent = "u"
[[field.node]]
type = "sphere"
name = "s"
[[field.node]]
type = "sphere"
parent = "s"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:15:1: field.node[3].parent: \"s\" is a sphere, not "
                                   "an operator"));
    r = readTree(R"(
[[field.node]]
type = "union"
name = "u"
parent = "w"
[[field.node]]
type = "union"
name = "w"
parent = "u"
)");
    EXPECT_TRUE(contains(r.errors, "field.node[0].parent: \"w\" is inside this node (a cycle)"));
    r = readTree(R"(
[[field.node]]
type = "union"
name = "u"
[[field.node]]
type = "sphere"
name = "u"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:7:1: field.node[1].name: \"u\" is already the name of "
                                   "field.node[0]"));
    r = readTree(R"(
[[field.node]]
type = "union"
name = "u"
[[field.node]]
type = "sphere"
)");
    EXPECT_TRUE(contains(r.errors, "t.toml:2:1: field.node[0]: the union \"u\" has no children"));
}

TEST(SdfSceneTree, RejectsAnArrayThatIsNotOfTables) {
    const toml::table root = toml::parse(std::string("[field]\nnode = 3\n"), std::string("t.toml"));
    Context cx{"t.toml", {}};
    Problems pr;
    EXPECT_FALSE(readSdfTree(*root["field"]["node"].node(), "field.node", cx, pr));
    ASSERT_EQ(pr.lines().size(), 1u);
    EXPECT_TRUE(contains(pr.lines()[0], "t.toml:2:8: field.node: expected one or more "
                                        "[[field.node]] tables, found"));
}
