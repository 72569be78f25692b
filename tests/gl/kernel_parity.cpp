/// @file kernel_parity.cpp
/// @brief Runs a kernel parity case on the GL context and compares (see kernel_parity.h).
#include "tests/gl/kernel_parity.h"

#include <cstdio>
#include <limits>

#include "core/kernels/source.h"
#include "plugin/realtime/gl_compute.h"

namespace nimbus::parity {
namespace {

constexpr unsigned kLocalSize = 64;

std::string load(const Field& f, const std::string& word) {
    switch (f.kind) {
    case Word::Float:
        return "uintBitsToFloat(" + word + ")";
    case Word::Uint:
        return word;
    case Word::Int:
        return "int(" + word + ")";
    case Word::Bool:
        return "(" + word + " != 0u)";
    }
    return word;
}

std::string store(const Field& f, const std::string& value) {
    switch (f.kind) {
    case Word::Float:
        return "floatBitsToUint(" + value + ")";
    case Word::Uint:
        return value;
    case Word::Int:
        return "uint(" + value + ")";
    case Word::Bool:
        return "(" + value + " ? 1u : 0u)";
    }
    return value;
}

std::string formatWord(const Field& f, std::uint32_t w) {
    char buf[64];
    switch (f.kind) {
    case Word::Float:
        std::snprintf(buf, sizeof(buf), "%.9g [0x%08x]", double(std::bit_cast<float>(w)), w);
        break;
    case Word::Uint:
        std::snprintf(buf, sizeof(buf), "%uu", w);
        break;
    case Word::Int:
        std::snprintf(buf, sizeof(buf), "%d", std::bit_cast<int>(w));
        break;
    case Word::Bool:
        std::snprintf(buf, sizeof(buf), "%s", w ? "true" : "false");
        break;
    }
    return buf;
}

std::string formatValue(const std::vector<Field>& fields, const std::uint32_t* w) {
    if (fields.size() == 1 && fields[0].access.empty()) return formatWord(fields[0], w[0]);
    std::string s = "{";
    for (std::size_t i = 0; i < fields.size(); ++i) {
        if (i) s += ", ";
        s += fields[i].access + " = " + formatWord(fields[i], w[i]);
    }
    return s + "}";
}

} // namespace

std::int64_t ulpDistance(std::uint32_t a, std::uint32_t b) {
    const float fa = std::bit_cast<float>(a), fb = std::bit_cast<float>(b);
    if (std::isnan(fa) || std::isnan(fb))
        return std::isnan(fa) && std::isnan(fb) ? 0 : std::numeric_limits<std::int64_t>::max();
    auto ordered = [](std::uint32_t x) {
        return (x & 0x80000000u) ? -std::int64_t(x & 0x7fffffffu) : std::int64_t(x);
    };
    const std::int64_t d = ordered(a) - ordered(b);
    return d < 0 ? -d : d;
}

std::string paritySource(const KernelCase& c) {
    std::string s = "#version 430\n";
    s += kern::glslLibrary();
    // the harness's own lines report as source string 1000
    s += "#line 1 1000\n";
    s += "layout(local_size_x = " + std::to_string(kLocalSize) + ") in;\n";
    s += "layout(std430, binding = 0) readonly buffer ParityIn { uint parityIn[]; };\n";
    s += "layout(std430, binding = 1) writeonly buffer ParityOut { uint parityOut[]; };\n";
    s += "void main() {\n";
    s += "    uint parityIndex = gl_GlobalInvocationID.x;\n";
    s += "    if (parityIndex >= " + std::to_string(c.count) + "u) return;\n";
    s += "    uint parityAt = parityIndex * " + std::to_string(c.inWords()) + "u;\n";
    std::size_t word = 0;
    for (std::size_t a = 0; a < c.argTypes.size(); ++a) {
        // field by field (member paths reach into nested structs such as CumulusParams.layer)
        const std::string name = "a" + std::to_string(a);
        const auto& fields = c.argFields[a];
        if (fields.size() == 1 && fields[0].access.empty()) {
            s += "    " + c.argTypes[a] + " " + name + " = " +
                 load(fields[0], "parityIn[parityAt + " + std::to_string(word++) + "u]") + ";\n";
            continue;
        }
        s += "    " + c.argTypes[a] + " " + name + ";\n";
        for (std::size_t k = 0; k < fields.size(); ++k, ++word)
            s += "    " + name + fields[k].access + " = " +
                 load(fields[k], "parityIn[parityAt + " + std::to_string(word) + "u]") + ";\n";
    }
    s += "    " + c.resultType + " r;\n";
    s += "    " + c.body + "\n";
    s += "    uint parityOutAt = parityIndex * " + std::to_string(c.resultFields.size()) + "u;\n";
    for (std::size_t k = 0; k < c.resultFields.size(); ++k)
        s += "    parityOut[parityOutAt + " + std::to_string(k) +
             "u] = " + store(c.resultFields[k], "r" + c.resultFields[k].access) + ";\n";
    s += "}\n";
    return s;
}

ParityResult runParity(const KernelCase& c) {
    ParityResult res;
    res.count = c.count;
    // a seed per case name: reproducible, and different rows draw different inputs
    std::uint64_t seed = 1469598103934665603ull;
    for (char ch : c.name) seed = (seed ^ std::uint8_t(ch)) * 1099511628211ull;
    std::vector<std::uint32_t> in, expected;
    std::vector<float> allowed;
    c.evaluate(c.count, seed, in, expected, allowed);

    const std::string source = paritySource(c);
    gl::ComputeProgram program(source);
    if (!program.valid()) {
        res.error = program.log() +
                    "\n(source string n = kernel n of kern::kernelSources(), 1000 = the harness "
                    "main; Mesa prints 0 for some errors, the line is still the file's)\n" +
                    source.substr(source.find("#line 1 1000"));
        return res;
    }
    const std::size_t outWords = c.resultFields.size();
    std::vector<std::uint32_t> got(expected.size());
    if (!gl::runCompute(program, in, got, std::size_t(c.count), &res.error)) return res;
    res.ran = true;

    const std::size_t inWords = c.inWords();
    double worstFailure = -1.0;
    for (int i = 0; i < c.count; ++i) {
        bool failed = false;
        double badness = 0.0; // the failure's size: share of the tolerance, 1e30 for exact words
        double allowedAtWorst = 0.0;
        for (std::size_t k = 0; k < outWords; ++k) {
            std::uint32_t e = expected[std::size_t(i) * outWords + k];
            std::uint32_t g = got[std::size_t(i) * outWords + k];
            if (c.resultFields[k].kind != Word::Float) {
                if (e != g) {
                    failed = true;
                    badness = 1e30;
                }
                continue;
            }
            // GLSL may flush denormals to zero (llvmpipe does): compare them as zeros
            if ((e & 0x7f800000u) == 0u) e &= 0x80000000u;
            if ((g & 0x7f800000u) == 0u) g &= 0x80000000u;
            const std::int64_t ulps = ulpDistance(e, g);
            const float fe = std::bit_cast<float>(e), fg = std::bit_cast<float>(g);
            const double diff = std::isfinite(fe) && std::isfinite(fg)
                                    ? std::abs(double(fe) - double(fg))
                                    : (ulps ? std::numeric_limits<double>::infinity() : 0.0);
            res.worstUlp = std::max(res.worstUlp, ulps);
            res.worstAbs = std::max(res.worstAbs, diff);
            // the tolerance's parts add up: ulps of the C++ value, abs, rel and the allowance
            const double ulpSize = std::ldexp(
                1.0, std::max(std::ilogb(std::max(std::abs(fe), std::numeric_limits<float>::min())),
                              -126) -
                         23);
            const double allowedAbs = double(c.tolerance.ulps) * ulpSize + double(c.tolerance.abs) +
                                      double(c.tolerance.rel) * std::abs(double(fe)) +
                                      double(allowed[std::size_t(i) * outWords + k]);
            const double share = diff <= allowedAbs ? (allowedAbs > 0.0 ? diff / allowedAbs : 0.0)
                                 : allowedAbs > 0.0 ? diff / allowedAbs
                                                    : std::numeric_limits<double>::infinity();
            res.worstShare = std::max(res.worstShare, share);
            if (share > 1.0) {
                failed = true;
                badness = std::max(badness, share);
                if (badness == share) allowedAtWorst = allowedAbs;
            }
        }
        if (!failed) continue;
        ++res.failures;
        if (badness <= worstFailure) continue;
        worstFailure = badness;
        std::string s = "input #" + std::to_string(i) + ":";
        const std::uint32_t* w = in.data() + std::size_t(i) * inWords;
        for (std::size_t a = 0; a < c.argFields.size(); ++a) {
            s += "\n  a" + std::to_string(a) + " (" + c.argTypes[a] +
                 ") = " + formatValue(c.argFields[a], w);
            w += c.argFields[a].size();
        }
        s += "\n  C++  r = " +
             formatValue(c.resultFields, expected.data() + std::size_t(i) * outWords);
        s += "\n  GLSL r = " + formatValue(c.resultFields, got.data() + std::size_t(i) * outWords);
        if (badness < 1e30) {
            char buf[96];
            std::snprintf(buf, sizeof(buf), "\n  %.3g x the tolerance (absolute allowance %.3g)",
                          badness, allowedAtWorst);
            s += buf;
        }
        res.worstFailure = s;
    }
    return res;
}

} // namespace nimbus::parity
