/// @file params_gardner.cpp
/// @brief Scene-file parameter table: the rows of [field] with kind = "gardner" (the cloud's
///        defaults), and its tables [[field.ellipsoid]] and [field.scatter] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

namespace {

const std::string kTexture = " (core/kernels/gardner.glsl)";

/// The rows every ellipsoid shares with the cloud: defaults in [field], optional per ellipsoid.
struct ShapeRow {
    const char* key;
    Range range;
    const char* doc;
    float GardnerShapeDesc::*shape;     ///< null: a texture member
    float GardnerTextureDesc::*texture; ///< null: a shape member
    std::optional<float> GardnerEllipsoidDesc::*own;
};

const ShapeRow kShapeRows[] = {
    {"t1",
     {},
     "Texture threshold T1 at the ellipsoid's centre: Gardner's transparency is a = 1 - (I - T1 - "
     "(T2 - T1)(1 - g)) / D, the density 1 - a.",
     &GardnerShapeDesc::t1,
     nullptr,
     &GardnerEllipsoidDesc::t1},
    {"t2",
     {},
     "Texture threshold T2 at the surface (>= T1): larger = softer, more broken edges.",
     &GardnerShapeDesc::t2,
     nullptr,
     &GardnerEllipsoidDesc::t2},
    {"d", above(0), "Ramp width D of the transparency: small = hard edges.", &GardnerShapeDesc::d,
     nullptr, &GardnerEllipsoidDesc::d},
    {"density", atLeast(0), "Density of an opaque point (the density is this times 1 - a).",
     &GardnerShapeDesc::density, nullptr, &GardnerEllipsoidDesc::density},
    {"frequency", above(0),
     "Cycles per world unit of the texture's first term; term i has 2^(i-1) times it.", nullptr,
     &GardnerTextureDesc::frequency, &GardnerEllipsoidDesc::frequency},
    {"k", above(0), "The texture's maximum (Gardner's k, normalised: k = 1 gives I <= 1).", nullptr,
     &GardnerTextureDesc::k, &GardnerEllipsoidDesc::k},
    {"t0", atLeast(0),
     "T0, added to every term of the sine sums: larger = less contrast in the texture.", nullptr,
     &GardnerTextureDesc::t0, &GardnerEllipsoidDesc::t0},
    {"phase", closed(-10, 10),
     "Amplitude of the phase shifts between the sums (Gardner: pi/2 = 1.5708); 0 = plain "
     "sine products.",
     nullptr, &GardnerTextureDesc::phase, &GardnerEllipsoidDesc::phase},
};

const Range kTerms = closed(1, 12);
const char* kTermsDoc = "Number of terms of each sine sum (frequencies f, 2f, ..., 2^(n-1) f; "
                        "amplitudes falling by 1/sqrt(2) per term).";

GardnerDesc& gardner(Staging& s) {
    return s.file.scene.field.gardner;
}

} // namespace

void addGardnerParams(std::vector<Param>& t) {
    const Section<GardnerShapeDesc> ga{
        "field", [](Staging& s) -> GardnerShapeDesc& { return gardner(s).defaults; },
        FieldKind::Gardner};
    for (const ShapeRow& r : kShapeRows) {
        if (r.shape)
            t.push_back(ga.param(r.key, r.range,
                                 std::string(r.doc) + " Default of every ellipsoid.", r.shape));
        else
            t.push_back(ga.param(r.key, r.range,
                                 std::string(r.doc) + " Default of every ellipsoid.",
                                 &GardnerShapeDesc::texture, r.texture));
        if (std::string(r.key) == "k") // terms after frequency and k, in the reference's order
            t.push_back(ga.param("terms", kTerms,
                                 std::string(kTermsDoc) + " Default of every ellipsoid.",
                                 &GardnerShapeDesc::texture, &GardnerTextureDesc::terms));
    }
    t.push_back(ga.param("texture_offset", {},
                         "Added to the world point before the sine sums: moves the texture "
                         "through the cloud.",
                         &GardnerShapeDesc::texture, &GardnerTextureDesc::offset));
}

const std::vector<FieldSubTable>& fieldSubTables() {
    static const std::vector<FieldSubTable> table = [] {
        std::vector<FieldSubTable> t = {
            {FieldKind::Gardner, "ellipsoid", true,
             "One textured ellipsoid of a Gardner cloud. The density is 0 outside it; inside, "
             "Gardner's transparency a = 1 - (I - T1 - (T2 - T1)(1 - g)) / D (clamped to [0, 1], "
             "g = 1 - r^2 the normalised falloff, 1 at the centre and 0 on the surface, I the "
             "sine-sum "
             "texture) gives the density `density` x (1 - a). Where ellipsoids overlap the larger "
             "density wins. The texture and shape keys left out take the values of [field].",
             [](Staging& s, Where w) {
                 gardner(s).ellipsoids.push_back(GardnerEllipsoidDesc{});
                 s.ellipsoidWhere.push_back(w);
             }},
            {FieldKind::Gardner, "scatter", false,
             "Builds a cumulus from `count` ellipsoids the way Gardner and Elinas & Stuerzlinger "
             "do, deterministic per `seed`: about a fifth large flattened body ellipsoids standing "
             "on "
             "the flat base, a sixth wide thin ones along the base, the rest smaller ellipsoids "
             "heaped on the top and sides of earlier ones, all inside the box `extent` above "
             "`center`. Each takes the shape and texture keys of [field]; the seed also moves the "
             "texture. May be combined with [[field.ellipsoid]] tables.",
             [](Staging& s, Where w) {
                 gardner(s).scatter.enabled = true;
                 s.gardnerScatterWhere = w;
             }},
            automatonWindTable(),
        };
        addAdvectTables(t);
        return t;
    }();
    return table;
}

const std::vector<Param>& fieldSubRegistry() {
    static const std::vector<Param> table = [] {
        std::vector<Param> t;
        const Section<GardnerEllipsoidDesc> el{
            "field.ellipsoid",
            [](Staging& s) -> GardnerEllipsoidDesc& { return gardner(s).ellipsoids[s.element]; }};
        t.push_back(el.param("center", {}, "Centre (world units).", &GardnerEllipsoidDesc::center));
        t.push_back(el.param("radii", above(0), "Radii along the ellipsoid's x, y and z axes.",
                             &GardnerEllipsoidDesc::radii));
        t.push_back(el.param("rotate", {}, "Rotation in degrees about x, then y, then z.",
                             &GardnerEllipsoidDesc::rotate));
        for (const ShapeRow& r : kShapeRows) {
            t.push_back(
                el.param(r.key, r.range, std::string(r.doc) + " Unset: the [field] value.", r.own));
            if (std::string(r.key) == "k") {
                Param p = el.row("terms", Type::Int, kTerms,
                                 std::string(kTermsDoc) + " Unset: the [field] value.");
                p.set = [](Staging& s, const Value& v) {
                    gardner(s).ellipsoids[s.element].terms = int(v.i);
                };
                p.get = [](Staging& s) -> std::optional<Value> {
                    const std::optional<int>& n = gardner(s).ellipsoids[s.element].terms;
                    if (!n) return std::nullopt;
                    Value v;
                    v.i = *n;
                    return v;
                };
                t.push_back(p);
            }
        }

        const Section<GardnerScatterDesc> sc{
            "field.scatter", [](Staging& s) -> GardnerScatterDesc& { return gardner(s).scatter; }};
        t.push_back(sc.param("count", closed(1, 1000), "Number of ellipsoids.",
                             &GardnerScatterDesc::count));
        t.push_back(sc.param("size", above(0),
                             "Horizontal radius of the large body ellipsoids (world units); the "
                             "heaped ones are 0.45-0.7 of their parent's.",
                             &GardnerScatterDesc::size));
        t.push_back(sc.param("seed", kUInt32, "Seed of the placement and of the texture's offset.",
                             &GardnerScatterDesc::seed));
        t.push_back(sc.param("center", {}, "Centre of the cloud's flat base (world units).",
                             &GardnerScatterDesc::center));
        t.push_back(sc.param("extent", above(0),
                             "Width (x), height (y) and depth (z) of the box above `center` that "
                             "holds the cloud.",
                             &GardnerScatterDesc::extent));
        addAutomatonSubParams(t);
        addAdvectSubParams(t);
        return t;
    }();
    return table;
}

} // namespace nimbus::io::scene
