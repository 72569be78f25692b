/// @file params_output.cpp
/// @brief Scene-file parameter table: the rows of [output] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addOutputParams(std::vector<Param>& t) {
    const Section<OutputDesc> out{"output",
                                  [](Staging& s) -> OutputDesc& { return s.file.output; }};
    t.push_back(out.param("path", {},
                          "EXR file name pattern; needs a frame token when several frames are "
                          "rendered.",
                          &OutputDesc::path)
                    .neutralToPixels()
                    .checkedBy([](const Value& v) -> std::string {
                        if (endsWithNoCase(v.s, ".exr") && v.s.size() > 4) return "";
                        return "expected a file name ending in .exr, found " + quote(v.s);
                    }));
    t.push_back(out.param("color_space", {}, "Colour space of the EXR pixels (an OCIO name).",
                          &OutputDesc::colorSpace)
                    .checkedBy(nonEmpty));
    {
        Param p = out.row("aovs", Type::WordList, {},
                          "Extra EXR layers: transmittance (RGB, of the whole camera ray) and "
                          "depth (distance where transmittance first drops below 0.5).");
        p.words = {"transmittance", "depth"};
        p.set = [](Staging& s, const Value& v) {
            AovSet& a = s.file.output.aovs;
            a = AovSet{};
            for (const std::string& w : v.list) {
                if (w == "transmittance") a.transmittance = true;
                if (w == "depth") a.depth = true;
            }
        };
        p.get = [](Staging& s) -> std::optional<Value> {
            Value v;
            if (s.file.output.aovs.transmittance) v.list.push_back("transmittance");
            if (s.file.output.aovs.depth) v.list.push_back("depth");
            return v;
        };
        t.push_back(p);
    }
    t.push_back(out.param("preview", {},
                          "PNG file name pattern of a display-referred preview; \"\" = none.",
                          &OutputDesc::preview)
                    .neutralToPixels()
                    .checkedBy([](const Value& v) -> std::string {
                        if (v.s.empty() || (endsWithNoCase(v.s, ".png") && v.s.size() > 4))
                            return "";
                        return "expected \"\" or a file name ending in .png, found " + quote(v.s);
                    }));
    auto previewOn = [](const SceneFile& f) { return !f.output.preview.empty(); };
    t.push_back(out.param("display", {}, "OCIO display of the preview.", &OutputDesc::display)
                    .neutralToPixels()
                    .checkedBy(nonEmpty)
                    .usedWhen("output.preview != \"\"", previewOn));
    t.push_back(out.param("view", {}, "OCIO view of the preview.", &OutputDesc::view)
                    .neutralToPixels()
                    .checkedBy(nonEmpty)
                    .usedWhen("output.preview != \"\"", previewOn));
}

} // namespace nimbus::io::scene
