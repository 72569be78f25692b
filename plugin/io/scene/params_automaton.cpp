/// @file params_automaton.cpp
/// @brief Scene-file parameter table: the rows of [field] with kind = "automaton" (Dobashi's
///        cellular automaton, core/fields/automaton_field.h) and its [[field.wind]] table
///        (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

namespace {

AutomatonDesc& automaton(Staging& s) {
    return s.file.scene.field.automaton;
}

/// Whole numbers >= 1 whose product stays within kMaxAutomatonCells.
std::string resolutionProblem(const Value& v) {
    double cells = 1.0;
    for (double x : v.v) {
        if (x != std::floor(x)) return "expected whole numbers of cells, found " + formatDouble(x);
        cells *= x;
    }
    if (cells <= kMaxAutomatonCells) return "";
    return formatDouble(v.v[0]) + " x " + formatDouble(v.v[1]) + " x " + formatDouble(v.v[2]) +
           " is " + formatDouble(cells) + " cells; the limit is " +
           formatDouble(kMaxAutomatonCells) +
           " (2^24: the field keeps about eight float grids of this size, 34 bytes a cell)";
}

} // namespace

void addAutomatonParams(std::vector<Param>& t) {
    const Section<AutomatonDesc> au{"field", &automaton, FieldKind::Automaton};
    Param res = au.row("resolution", Type::Vec3, closed(1, 65536),
                       "Cells of the automaton's grid along x, y (up) and z; the grid spans "
                       "bounds_min to bounds_max (cells need not be cubes). Sizes below are in "
                       "cells.");
    res.set = [](Staging& s, const Value& v) {
        automaton(s).res = ivec3(int(v.v[0]), int(v.v[1]), int(v.v[2]));
    };
    res.get = [](Staging& s) -> std::optional<Value> {
        Value v;
        const ivec3 r = automaton(s).res;
        v.v = {double(r.x), double(r.y), double(r.z)};
        return v;
    };
    res.check = resolutionProblem;
    t.push_back(res);
    t.push_back(au.param("bounds_min", {}, "Lower corner of the grid (world units).",
                         &AutomatonDesc::bounds, &Box::lo));
    t.push_back(au.param("bounds_max", {}, "Upper corner of the grid (world units).",
                         &AutomatonDesc::bounds, &Box::hi));
    t.push_back(au.param("density", atLeast(0),
                         "Density of a fully cloudy cell (the smoothed cloud bits, 0..1, times "
                         "this).",
                         &AutomatonDesc::density));
    t.push_back(au.param("seed", kUInt32,
                         "Every random number of the simulation derives from it (and the frame's "
                         "time): a frame rendered alone equals the same frame of a sequence.",
                         &AutomatonDesc::seed));
    t.push_back(au.param("sim_step", closed(0.001, 10),
                         "Seconds of one simulation step (Fizimayer: about 1/10 s); frames in "
                         "between are interpolated and advected by the wind.",
                         &AutomatonDesc::simStep));
    t.push_back(au.param("warmup", closed(0, 3600),
                         "Seconds simulated before time 0, so that the first frame shows settled "
                         "clouds (the cover reaches its target within about 7 s from an empty "
                         "start). Costs warmup / sim_step steps once per render.",
                         &AutomatonDesc::warmup));
    t.push_back(au.param("cover", closed(0, 1),
                         "Target cloud cover (fraction of the grid's columns holding cloud) that "
                         "the number of region ellipsoids is adapted to hold.",
                         &AutomatonDesc::targetCover));
    t.push_back(au.param("cover_tolerance", closed(0, 1),
                         "No adaptation while the cover is within this of `cover`.",
                         &AutomatonDesc::coverTolerance));
    t.push_back(au.param("ellipsoids", closed(0, 100000),
                         "Region ellipsoids at the start (Fizimayer's cloud density).",
                         &AutomatonDesc::ellipsoids));
    t.push_back(au.param("min_ellipsoids", closed(0, 100000),
                         "Fewest region ellipsoids the adaptation keeps.",
                         &AutomatonDesc::minEllipsoids));
    t.push_back(au.param("max_ellipsoids", closed(0, 100000),
                         "Most region ellipsoids the adaptation keeps.",
                         &AutomatonDesc::maxEllipsoids));
    t.push_back(au.param("adapt_period", closed(1, 1000000),
                         "Steps between two changes of the ellipsoid count.",
                         &AutomatonDesc::adaptPeriod));
    t.push_back(au.param("size", above(0),
                         "Mean horizontal semi-axis of a region ellipsoid (cells); x and z are "
                         "stretched by a random factor a in [0.75, 1.25] and 1 / a.",
                         &AutomatonDesc::sizeMean));
    t.push_back(au.param("size_spread", atLeast(0),
                         "Half-width of the uniform spread of `size` (cells).",
                         &AutomatonDesc::sizeVar));
    t.push_back(au.param("height_ratio", above(0),
                         "Vertical semi-axis of an ellipsoid over its horizontal one.",
                         &AutomatonDesc::heightRatio));
    t.push_back(au.param("lifetime", above(0), "Mean lifetime of an ellipsoid (seconds).",
                         &AutomatonDesc::lifeMean));
    t.push_back(au.param("lifetime_spread", atLeast(0),
                         "Half-width of the uniform spread of `lifetime` (seconds).",
                         &AutomatonDesc::lifeVar));
    t.push_back(au.param("shrink_time", atLeast(0),
                         "Seconds at the end of a life over which an ellipsoid shrinks to "
                         "nothing (clouds dissolve instead of popping).",
                         &AutomatonDesc::shrinkTime));
    t.push_back(au.param("region_margin", atLeast(0),
                         "Ellipsoids live in the grid grown by this many cells in x and z, so "
                         "clouds drift in and out.",
                         &AutomatonDesc::regionMargin));
    t.push_back(au.pair("layer", closed(0, 1),
                        "Heights of the ellipsoids' centres, [min, max] as fractions of the "
                        "grid's height.",
                        &AutomatonDesc::layerLo, &AutomatonDesc::layerHi));
    t.push_back(au.param("p_humidity", closed(0, 1),
                         "Probability per step of humidity regeneration at an ellipsoid's "
                         "centre (falling to 0 at its surface).",
                         &AutomatonDesc::pHum));
    t.push_back(au.param("p_activation", closed(0, 1),
                         "Probability per step of activation at an ellipsoid's centre.",
                         &AutomatonDesc::pAct));
    t.push_back(au.param("p_extinction", closed(0, 1),
                         "Probability per step that a cloud cell outside every ellipsoid "
                         "vanishes (0 at a centre).",
                         &AutomatonDesc::pExt));
    t.push_back(au.param("start_full", {},
                         "Start with every cell cloudy instead of empty (the adaptation then "
                         "thins it).",
                         &AutomatonDesc::startFull));
    t.push_back(au.param("checkpoint_every", closed(0, 1000000),
                         "Steps between kept copies of the state (about 1 bit x 3 per cell "
                         "each): rendering frames out of order re-simulates from the nearest "
                         "one instead of step 0. 0: none.",
                         &AutomatonDesc::checkpointEvery));
}

void addAutomatonSubParams(std::vector<Param>& t) {
    const Section<AutomatonWindRow> wi{
        "field.wind", [](Staging& s) -> AutomatonWindRow& { return automaton(s).wind[s.element]; }};
    t.push_back(wi.param("altitude", {},
                         "World altitude (y) of this row; rows must be given in strictly "
                         "increasing altitude.",
                         &AutomatonWindRow::altitude));
    t.push_back(wi.param("wind", closed(-1e6, 1e6),
                         "Wind at this altitude (world units per second); y must be 0. Linear "
                         "between rows, the nearest row's above and below the table.",
                         &AutomatonWindRow::wind)
                    .checkedBy([](const Value& v) -> std::string {
                        if (v.v[1] == 0.0) return "";
                        return "the automaton's wind is horizontal: expected y = 0, found " +
                               formatDouble(v.v[1]);
                    }));
}

FieldSubTable automatonWindTable() {
    return {FieldKind::Automaton, "wind", true,
            "One row of the layered wind that carries the automaton's cloud (its cells are "
            "shifted per layer, Dobashi 2000, and its region ellipsoids move with it): the "
            "horizontal wind at one altitude, linear in altitude between rows (shear), the "
            "nearest row's outside the table. No rows: still air.",
            [](Staging& s, Where w) {
                automaton(s).wind.push_back(AutomatonWindRow{});
                s.windWhere.push_back(w);
            }};
}

} // namespace nimbus::io::scene
