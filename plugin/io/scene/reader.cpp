/// @file reader.cpp
/// @brief Text helpers, problem locations, reading TOML nodes against a row, `--set` overrides
///        and the validation of sections and [[array]] tables (see reader.h).
#include "plugin/io/scene/reader.h"
#include "plugin/io/scene/params_sdf.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <stdexcept>

#include "core/tracking/volumes.h"
#include "plugin/io/frames.h"

namespace nimbus::io::scene {

// ------------------------------------------------------------------------------------------
// Text helpers
// ------------------------------------------------------------------------------------------

/// Shortest text that reads back as the same float (values are stored as float).
std::string formatFloat(double x) {
    char buf[64];
    auto r = std::to_chars(buf, buf + sizeof buf, float(x));
    return std::string(buf, r.ptr);
}

/// Shortest text of a double: what the user wrote, for error messages.
std::string formatDouble(double x) {
    char buf[64];
    auto r = std::to_chars(buf, buf + sizeof buf, x);
    return std::string(buf, r.ptr);
}

/// A TOML basic string.
std::string quote(std::string_view s) {
    std::string out = "\"";
    for (char c : s) {
        switch (c) {
        case '"':
            out += "\\\"";
            break;
        case '\\':
            out += "\\\\";
            break;
        case '\n':
            out += "\\n";
            break;
        case '\t':
            out += "\\t";
            break;
        case '\r':
            out += "\\r";
            break;
        default:
            if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
                char buf[8];
                std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
                out += buf;
            } else {
                out += c;
            }
        }
    }
    return out + "\"";
}

std::string trim(std::string_view s) {
    size_t a = s.find_first_not_of(" \t");
    if (a == std::string_view::npos) return {};
    size_t b = s.find_last_not_of(" \t");
    return std::string(s.substr(a, b - a + 1));
}

std::string join(const std::vector<std::string>& items, std::string_view sep) {
    std::string out;
    for (size_t i = 0; i < items.size(); ++i) out += (i ? std::string(sep) : "") + items[i];
    return out;
}

std::string quotedList(const std::vector<std::string>& words) {
    std::vector<std::string> q;
    for (const std::string& w : words) q.push_back(quote(w));
    return join(q, ", ");
}

namespace {

size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            size_t up = row[j];
            char ca = char(std::tolower(static_cast<unsigned char>(a[i - 1])));
            char cb = char(std::tolower(static_cast<unsigned char>(b[j - 1])));
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (ca == cb ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

} // namespace

/// " (did you mean "x"?)" for the closest candidate, or "".
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates) {
    std::string best;
    size_t bestDistance = std::max<size_t>(2, word.size() / 3) + 1;
    for (const std::string& c : candidates) {
        size_t d = editDistance(word, c);
        if (d < bestDistance) {
            bestDistance = d;
            best = c;
        }
    }
    return best.empty() ? "" : " (did you mean " + quote(best) + "?)";
}

bool endsWithNoCase(const std::string& s, std::string_view suffix) {
    if (s.size() < suffix.size()) return false;
    for (size_t i = 0; i < suffix.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i])
            return false;
    return true;
}

// ------------------------------------------------------------------------------------------
// Locations and problems
// ------------------------------------------------------------------------------------------

Where Context::at(const toml::source_region& r) const {
    if (r.path)
        for (size_t i = 0; i < labels.size(); ++i)
            if (*r.path == labels[i]) return {labels[i], int(i) + 1, 0, 0};
    int line = std::max(1, int(r.begin.line));
    int column = std::max(1, int(r.begin.column));
    return {sourceName + ":" + std::to_string(line) + ":" + std::to_string(column), 0, line,
            column};
}

Where Context::atKey(const toml::key& k, const toml::node& n) const {
    Where w = at(n);
    if (w.rank > 0 || k.source().begin.line == 0) return w;
    return at(k.source());
}

std::vector<std::string> Problems::lines(std::string_view tag) {
    std::stable_sort(items.begin(), items.end(), [](const auto& a, const auto& b) {
        return std::tie(a.first.rank, a.first.line, a.first.column) <
               std::tie(b.first.rank, b.first.line, b.first.column);
    });
    std::vector<std::string> out;
    for (const auto& [w, text] : items) out.push_back(w.prefix + ": " + std::string(tag) + text);
    return out;
}

void Problems::raise() {
    throw SceneError(join(lines(), "\n"));
}

/// What a node holds, for "found ..." in messages.
std::string describe(const toml::node& n) {
    if (auto s = n.as_string()) {
        std::string v = s->get();
        if (v.size() > 60) v = v.substr(0, 57) + "...";
        return "string " + quote(v);
    }
    if (auto i = n.as_integer()) return std::to_string(i->get());
    if (auto f = n.as_floating_point()) {
        std::string text = formatDouble(f->get());
        if (std::isfinite(f->get()) && !std::isfinite(float(f->get())))
            text += " (too large for a float)";
        return text;
    }
    if (auto b = n.as_boolean()) return std::string("boolean ") + (b->get() ? "true" : "false");
    if (auto a = n.as_array()) {
        if (a->empty()) return "an empty array";
        return "an array of " + std::to_string(a->size()) +
               (a->size() == 1 ? " element" : " elements");
    }
    if (n.is_table()) return "a table";
    if (n.is_date()) return "a date";
    if (n.is_time()) return "a time";
    if (n.is_date_time()) return "a date-time";
    return "a value of unknown type";
}

// ------------------------------------------------------------------------------------------
// Types and ranges
// ------------------------------------------------------------------------------------------

std::string typeName(Type t) {
    switch (t) {
    case Type::Bool:
        return "bool";
    case Type::Int:
        return "integer";
    case Type::Number:
        return "number";
    case Type::Vec3:
        return "[x, y, z]";
    case Type::Rgb:
        return "RGB";
    case Type::Pair:
        return "[min, max]";
    case Type::String:
        return "string";
    case Type::Word:
        return "word";
    case Type::WordList:
        return "words";
    case Type::Frames:
        return "frame spec";
    }
    return "?";
}

std::string Range::text(bool integer) const {
    auto num = [&](double x) { return integer ? std::to_string(std::int64_t(x)) : formatFloat(x); };
    if (any()) return "";
    if (hi == kInf) return (loOpen ? "> " : ">= ") + num(lo);
    if (lo == -kInf) return (hiOpen ? "< " : "<= ") + num(hi);
    return (loOpen ? "(" : "[") + num(lo) + ", " + num(hi) + (hiOpen ? ")" : "]");
}

std::string Range::suffix(bool integer) const {
    std::string t = text(integer);
    if (t.empty()) return "";
    return (t[0] == '[' || t[0] == '(' ? " in " : " ") + t;
}

std::string Param::expected() const {
    switch (type) {
    case Type::Bool:
        return "true or false";
    case Type::Int:
        return "an integer" + range.suffix(true);
    case Type::Number:
        return "a number" + range.suffix(false);
    case Type::Vec3:
        return "an array of 3 numbers [x, y, z]" +
               (range.any() ? "" : ", each" + range.suffix(false));
    case Type::Rgb:
        return "an RGB colour: [r, g, b] or one grey number, each" + range.suffix(false);
    case Type::Pair:
        return "an array of 2 numbers [min, max], each" + range.suffix(false) + ", min <= max";
    case Type::String:
        return "a string";
    case Type::Word:
        return "one of " + quotedList(words);
    case Type::WordList:
        return "an array of words from " + quotedList(words);
    case Type::Frames:
        return "a frame spec string such as \"1-24\" (or one integer)";
    }
    return "?";
}

// ------------------------------------------------------------------------------------------
// Reading nodes, overrides, validation
// ------------------------------------------------------------------------------------------

namespace {

/// A number node checked against @p r as written and after rounding to float (what gets
/// stored), against the range's ends rounded to float too: a documented end such as 0.99 is
/// accepted (float(0.99) > 0.99 in double), 1e-50 for "> 0" is not (it is stored as 0).
std::optional<double> readNumber(const toml::node& n, const std::string& label, const Range& r,
                                 const Context& cx, Problems& pr) {
    std::optional<double> x;
    if (auto i = n.as_integer()) x = double(i->get());
    if (auto f = n.as_floating_point()) x = f->get();
    Range stored = r;
    stored.lo = double(float(r.lo));
    stored.hi = double(float(r.hi));
    if (x && r.contains(*x) && stored.contains(double(float(*x)))) return double(float(*x));
    pr.add(cx.at(n), label + ": expected a number" + r.suffix(false) + ", found " + describe(n));
    return std::nullopt;
}

} // namespace

std::optional<Value> read(const Param& p, const toml::node& n, const Context& cx, Problems& pr) {
    const std::string name = p.full();
    auto wrong = [&]() -> std::optional<Value> {
        pr.add(cx.at(n), name + ": expected " + p.expected() + ", found " + describe(n));
        return std::nullopt;
    };
    Value v;
    switch (p.type) {
    case Type::Bool:
        if (!n.is_boolean()) return wrong();
        v.b = n.as_boolean()->get();
        break;
    case Type::Int:
        if (!n.is_integer() || !p.range.contains(double(n.as_integer()->get()))) return wrong();
        v.i = n.as_integer()->get();
        break;
    case Type::Number: {
        auto x = readNumber(n, name, p.range, cx, pr);
        if (!x) return std::nullopt;
        v.x = *x;
        break;
    }
    case Type::Vec3:
    case Type::Rgb:
    case Type::Pair: {
        if (p.type == Type::Rgb && (n.is_integer() || n.is_floating_point())) {
            auto x = readNumber(n, name, p.range, cx, pr);
            if (!x) return std::nullopt;
            v.v = {*x, *x, *x};
            break;
        }
        size_t count = p.type == Type::Pair ? 2 : 3;
        const toml::array* a = n.as_array();
        if (!a || a->size() != count) return wrong();
        bool ok = true;
        for (size_t k = 0; k < count; ++k) {
            auto x = readNumber(*a->get(k), name + "[" + std::to_string(k) + "]", p.range, cx, pr);
            if (x) v.v[k] = *x;
            ok = ok && x.has_value();
        }
        if (!ok) return std::nullopt;
        break;
    }
    case Type::String:
        if (!n.is_string()) return wrong();
        v.s = n.as_string()->get();
        break;
    case Type::Word: {
        if (!n.is_string()) return wrong();
        v.s = n.as_string()->get();
        if (std::find(p.words.begin(), p.words.end(), v.s) == p.words.end()) {
            pr.add(cx.at(n), name + ": unknown value " + quote(v.s) + suggestion(v.s, p.words) +
                                 "; expected " + p.expected());
            return std::nullopt;
        }
        break;
    }
    case Type::WordList: {
        const toml::array* a = n.as_array();
        if (!a) return wrong();
        bool ok = true;
        for (size_t k = 0; k < a->size(); ++k) {
            const toml::node& e = *a->get(k);
            std::string label = name + "[" + std::to_string(k) + "]";
            if (!e.is_string()) {
                pr.add(cx.at(e), label + ": expected one of " + quotedList(p.words) + ", found " +
                                     describe(e));
                ok = false;
                continue;
            }
            std::string w = e.as_string()->get();
            if (std::find(p.words.begin(), p.words.end(), w) == p.words.end()) {
                pr.add(cx.at(e), label + ": unknown value " + quote(w) + suggestion(w, p.words) +
                                     "; expected one of " + quotedList(p.words));
                ok = false;
            } else if (std::find(v.list.begin(), v.list.end(), w) != v.list.end()) {
                pr.add(cx.at(e), label + ": " + quote(w) + " is listed twice");
                ok = false;
            }
            v.list.push_back(w);
        }
        if (!ok) return std::nullopt;
        break;
    }
    case Type::Frames:
        if (n.is_integer())
            v.s = std::to_string(n.as_integer()->get());
        else if (n.is_string())
            v.s = n.as_string()->get();
        else
            return wrong();
        try {
            parseFrameSpec(v.s);
        } catch (const std::invalid_argument& e) {
            pr.add(cx.at(n), name + ": " + e.what());
            return std::nullopt;
        }
        break;
    }
    if (p.check) {
        std::string problem = p.check(v);
        if (!problem.empty()) {
            pr.add(cx.at(n), name + ": " + problem);
            return std::nullopt;
        }
    }
    return v;
}

namespace {

bool isBareKey(std::string_view k) {
    if (k.empty()) return false;
    for (char c : k)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
    return true;
}

/// Moves @p from into @p into, replacing values; nodes keep their source (the override label).
void merge(toml::table& into, toml::table& from) {
    for (auto&& [k, v] : from) {
        toml::node* dst = into.get(k.str());
        if (dst && dst->is_table() && v.is_table())
            merge(*dst->as_table(), *v.as_table());
        else
            into.insert_or_assign(k, std::move(v));
    }
}

} // namespace

/// Parses one `section.key=value` override and merges it into @p root.
void applyOverride(toml::table& root, const std::string& label, const std::string& override) {
    auto fail = [&](const std::string& what) { throw SceneError(label + ": " + what); };
    size_t eq = override.find('=');
    if (eq == std::string::npos) fail("expected section.key=value, such as render.step=0.5");
    std::string key = trim(std::string_view(override).substr(0, eq));
    std::string value = trim(std::string_view(override).substr(eq + 1));
    if (override.find_first_of("\r\n") != std::string::npos)
        fail("an override must be a single line");
    std::vector<std::string> parts;
    for (size_t a = 0;;) {
        size_t b = key.find('.', a);
        parts.push_back(key.substr(a, b == std::string::npos ? std::string::npos : b - a));
        if (b == std::string::npos) break;
        a = b + 1;
    }
    for (const std::string& part : parts)
        if (!isBareKey(part))
            fail("expected section.key=value with a key such as render.step or frames, found key " +
                 quote(key));
    if (value.empty()) fail("missing value after '='");

    toml::table parsed;
    try {
        parsed = toml::parse(key + " = " + value, label);
    } catch (const toml::parse_error& e) {
        // A bare word (gradient, out/x.####.exr, 1-10) is taken as a string; anything that looks
        // like TOML syntax must be valid TOML.
        if (std::string_view("[{\"'").find(value[0]) != std::string_view::npos)
            fail(
                "invalid TOML value " + value + ": " + std::string(e.description()) +
                (value[0] == '[' || value[0] == '{' ? " (strings inside arrays need quotes)" : ""));
        try {
            parsed = toml::parse(key + " = " + quote(value), label);
        } catch (const toml::parse_error& e2) {
            // Not even a string: bytes that are not UTF-8, or control characters.
            fail("invalid value " + quote(value) + ": " + std::string(e2.description()));
        }
    }
    merge(root, parsed);
}

/// Checks every key of @p root against the registry and fills @p s.
void validate(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    const std::vector<std::string> sections = sectionNames();

    // Unknown top-level keys and sections that are not tables.
    for (auto&& [k, node] : root) {
        std::string name(k.str());
        const auto& arrays = arraySections();
        if (std::any_of(arrays.begin(), arrays.end(),
                        [&](const ArraySection& a) { return a.name == name; }))
            continue; // read below
        if (std::find(sections.begin(), sections.end(), name) != sections.end()) {
            if (!node.is_table())
                pr.add(cx.at(node),
                       name + ": expected a table ([" + name + "]), found " + describe(node));
            continue;
        }
        std::vector<std::string> topKeys = keysOf("", std::nullopt);
        if (std::find(topKeys.begin(), topKeys.end(), name) != topKeys.end()) continue;
        std::vector<std::string> candidates = topKeys;
        candidates.insert(candidates.end(), sections.begin(), sections.end());
        std::vector<std::string> bracketed;
        for (const std::string& sec : sections) bracketed.push_back("[" + sec + "]");
        for (const ArraySection& a : arraySections()) {
            candidates.push_back(a.name);
            bracketed.push_back("[[" + a.name + "]]");
        }
        pr.add(cx.atKey(k, node), "unknown key " + quote(name) + suggestion(name, candidates) +
                                      "; the top level accepts " + join(topKeys, ", ") +
                                      " and the sections " + join(bracketed, ", "));
    }

    // Values, in registry order: field.kind comes before the keys that depend on it.
    bool fieldKindKnown = true;
    for (const Param& p : registry()) {
        const toml::table* tbl = p.section.empty() ? &root : root[p.section].as_table();
        if (!tbl) continue;
        const toml::node* n = tbl->get(p.key);
        if (!n) continue;
        if (p.kind && (!fieldKindKnown || *p.kind != s.file.scene.field.kind)) continue;
        std::optional<Value> v = read(p, *n, cx, pr);
        if (v) {
            p.set(s, *v);
            s.given[p.full()] = cx.at(*n);
        } else if (p.full() == "field.kind") {
            fieldKindKnown = false;
        }
    }

    // Unknown keys inside sections, and keys of the other field kind.
    for (const std::string& sec : sections) {
        const toml::table* tbl = root[sec].as_table();
        if (!tbl) continue;
        std::optional<FieldKind> kind;
        if (sec == "field") kind = s.file.scene.field.kind;
        for (auto&& [k, node] : *tbl) {
            std::string key(k.str());
            // the SDF tree's [[field.node]] tables are read by readSdfTree (params_sdf.h)
            if (sec == "field" && key == "node" && kind == FieldKind::Sdf) continue;
            bool known = false;
            std::optional<FieldKind> otherKind;
            for (const Param& p : registry()) {
                if (p.section != sec || p.key != key) continue;
                if (!p.kind || !kind || *p.kind == *kind)
                    known = true;
                else
                    otherKind = p.kind;
            }
            for (const FieldSubTable& t : fieldSubTables()) { // read by validateFieldSubTables
                if (sec != "field" || t.key != key) continue;
                if (!kind || t.kind == *kind)
                    known = true;
                else
                    otherKind = t.kind;
            }
            if (known) continue;
            if (otherKind && !fieldKindKnown) continue; // the bad kind is reported already
            std::string name = sec + "." + key;
            if (otherKind) {
                pr.add(cx.atKey(k, node),
                       name + ": belongs to field.kind = " + quote(fieldKindName(*otherKind)) +
                           ", but field.kind is " + quote(fieldKindName(*kind)) +
                           "; with that kind [field] accepts " + join(keysOf(sec, kind), ", "));
                continue;
            }
            std::vector<std::string> keys = keysOf(sec, kind);
            std::string hint = suggestion(key, keys);
            pr.add(cx.atKey(k, node), "unknown key " + quote(name) + hint + "; [" + sec +
                                          "] accepts " + join(keys, ", "));
        }
    }
}

/// Reads the [[array]] tables of @p root.
void validateArrays(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    for (const ArraySection& a : arraySections()) {
        const toml::node* n = root.get(a.name);
        if (!n) continue;
        const toml::array* arr = n->as_array();
        if (!arr || !arr->is_array_of_tables()) {
            pr.add(cx.at(*n),
                   a.name + ": expected [[" + a.name + "]] tables, found " + describe(*n));
            continue;
        }
        std::vector<std::string> keys;
        for (const Param& p : arrayRegistry())
            if (p.section == a.name) keys.push_back(p.key);
        for (size_t i = 0; i < arr->size(); ++i) {
            const toml::table& tbl = *arr->get(i)->as_table();
            a.grow(s, cx.at(tbl));
            s.element = i;
            for (auto&& [k, node] : tbl) {
                const std::string key(k.str());
                if (a.name == "solid" && key == "node") { // the tree (params_sdf.h)
                    const std::string label = "solid[" + std::to_string(i) + "].node";
                    s.solidTreeRead.resize(s.file.scene.solids.size(), 0);
                    s.solidTreeRead[i] = 1; // given (its problems reported by readSdfTree)
                    if (std::optional<SdfNodeDesc> tree = readSdfTree(node, label, cx, pr))
                        s.file.scene.solids[i].root = std::move(*tree);
                    continue;
                }
                const Param* p = nullptr;
                for (const Param& q : arrayRegistry())
                    if (q.section == a.name && q.key == key) p = &q;
                if (!p) {
                    pr.add(cx.atKey(k, node), "unknown key " + quote(a.name + "." + key) +
                                                  suggestion(key, keys) + "; [[" + a.name +
                                                  "]] accepts " + join(keys, ", "));
                    continue;
                }
                Param named = *p;
                named.section = a.name + "[" + std::to_string(i) + "]";
                if (std::optional<Value> v = read(named, node, cx, pr)) p->set(s, *v);
            }
        }
    }
}

/// Reads the tables inside [field] that belong to its kind ([[field.ellipsoid]], ...).
void validateFieldSubTables(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    const toml::table* field = root["field"].as_table();
    if (!field) return;
    for (const FieldSubTable& t : fieldSubTables()) {
        if (t.kind != s.file.scene.field.kind) continue; // other kinds: reported by validate()
        const toml::node* n = field->get(t.key);
        if (!n) continue;
        const std::string name = "field." + t.key;
        std::vector<const toml::table*> tables;
        if (t.array) {
            const toml::array* arr = n->as_array();
            if (!arr || !arr->is_array_of_tables()) {
                pr.add(cx.at(*n),
                       name + ": expected [[" + name + "]] tables, found " + describe(*n));
                continue;
            }
            for (size_t i = 0; i < arr->size(); ++i) tables.push_back(arr->get(i)->as_table());
        } else {
            if (!n->is_table()) {
                pr.add(cx.at(*n),
                       name + ": expected a table ([" + name + "]), found " + describe(*n));
                continue;
            }
            tables.push_back(n->as_table());
        }
        std::vector<std::string> keys;
        for (const Param& p : fieldSubRegistry())
            if (p.section == name) keys.push_back(p.key);
        for (size_t i = 0; i < tables.size(); ++i) {
            const toml::table& tbl = *tables[i];
            t.grow(s, cx.at(tbl));
            s.element = i;
            const std::string label = t.array ? name + "[" + std::to_string(i) + "]" : name;
            for (auto&& [k, node] : tbl) {
                const std::string key(k.str());
                const Param* p = nullptr;
                for (const Param& q : fieldSubRegistry())
                    if (q.section == name && q.key == key) p = &q;
                if (!p) {
                    pr.add(cx.atKey(k, node),
                           "unknown key " + quote(label + "." + key) + suggestion(key, keys) +
                               "; " + (t.array ? "[[" + name + "]]" : "[" + name + "]") +
                               " accepts " + join(keys, ", "));
                    continue;
                }
                Param named = *p;
                named.section = label;
                if (std::optional<Value> v = read(named, node, cx, pr)) {
                    p->set(s, *v);
                    s.given[named.full()] = cx.at(node);
                }
            }
        }
    }
}

/// Required keys, names, scatter expansion and the default placements.
void resolveArrays(Staging& s, Problems& pr) {
    SceneDesc& sc = s.file.scene;
    std::vector<std::string> names{"field"};
    for (size_t i = 0; i < sc.volumes.size(); ++i) {
        const std::string& n = sc.volumes[i].name;
        const std::string label = "volume[" + std::to_string(i) + "]";
        if (n.empty())
            pr.add(s.volumeWhere[i], label + ": `name` is required");
        else if (std::find(names.begin(), names.end(), n) != names.end())
            pr.add(s.volumeWhere[i], label + ".name: " + quote(n) +
                                         (n == "field" ? " is the name of [field]"
                                                       : " is used by an earlier [[volume]]"));
        if (sc.volumes[i].field.vdb.path.empty())
            pr.add(s.volumeWhere[i], label + ": `path` is required");
        names.push_back(n);
    }
    for (size_t i = 0; i < sc.meshes.size(); ++i)
        if (sc.meshes[i].path.empty())
            pr.add(s.meshWhere[i], "mesh[" + std::to_string(i) + "]: `path` is required");
    s.solidTreeRead.resize(sc.solids.size(), 0);
    for (size_t i = 0; i < sc.solids.size(); ++i)
        if (!s.solidTreeRead[i])
            pr.add(s.solidWhere[i], "solid[" + std::to_string(i) +
                                        "]: needs its tree: one or more [[solid.node]] tables "
                                        "after it (see the reference)");
    auto indexOf = [&](const std::string& name, const Where& w, const std::string& label) {
        const auto it = std::find(names.begin(), names.end(), name);
        if (it != names.end()) return int(it - names.begin());
        pr.add(w, label + ".volume: no volume " + quote(name) + suggestion(name, names) +
                      "; known: " + quotedList(names));
        return 0;
    };
    const bool placed = !sc.instances.empty() || !s.scatters.empty();
    for (size_t i = 0; i < sc.instances.size(); ++i)
        sc.instances[i].volume = indexOf(s.instanceVolumes[i].volume, s.instanceVolumes[i].where,
                                         "instance[" + std::to_string(i) + "]");
    for (size_t i = 0; i < s.scatters.size(); ++i) {
        const Staging::Scatter& c = s.scatters[i];
        const int v = indexOf(c.volume, c.where, "scatter[" + std::to_string(i) + "]");
        if (glm::any(glm::greaterThan(c.regionMin, c.regionMax)))
            pr.add(c.where, "scatter[" + std::to_string(i) + "]: region_min " +
                                "must not exceed region_max on any axis");
        std::uint32_t state = c.seed * 747796405u + 2891336453u;
        auto uniform = [&state]() { // PCG-style hash chain: deterministic, seed-local
            state = state * 747796405u + 2891336453u;
            std::uint32_t w = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
            return float((w >> 22u) ^ w) * (1.0f / 4294967296.0f);
        };
        for (std::int64_t k = 0; k < c.count; ++k) {
            InstanceDesc d;
            d.volume = v;
            const vec3 u(uniform(), uniform(), uniform());
            d.translate = glm::mix(c.regionMin, c.regionMax, u);
            d.scale = vec3(glm::mix(c.scaleMin, c.scaleMax, uniform()));
            d.rotate = vec3(0.0f, glm::mix(c.yawMin, c.yawMax, uniform()), 0.0f);
            d.density = glm::mix(c.densityMin, c.densityMax, uniform());
            sc.instances.push_back(d);
        }
    }
    if (!placed && !sc.volumes.empty())
        for (int v = 0; v <= int(sc.volumes.size()); ++v) {
            InstanceDesc d;
            d.volume = v;
            sc.instances.push_back(d);
        }
    if (placed) // volumes nobody places are never read
        for (size_t i = 0; i < sc.volumes.size(); ++i) {
            if (!isPlaced(sc, int(i) + 1) && i < s.volumeWhere.size())
                s.file.warnings.push_back(s.volumeWhere[i].prefix + ": warning: volume " +
                                          quote(sc.volumes[i].name) +
                                          " is not placed by any [[instance]] or [[scatter]]; "
                                          "it is not read");
        }
}

/// Keys given although their value is ignored (e.g. medium.g with an isotropic phase).
std::vector<std::string> ignoredKeyWarnings(const Staging& s) {
    Problems w;
    for (const Param& p : registry()) {
        auto it = s.given.find(p.full());
        if (it == s.given.end() || !p.used || p.used(s.file)) continue;
        if (p.kind && *p.kind != s.file.scene.field.kind) continue;
        w.add(it->second, p.full() + " is ignored: it is used only when " + p.usedWhenText);
    }
    return w.lines("warning: ");
}

} // namespace nimbus::io::scene
