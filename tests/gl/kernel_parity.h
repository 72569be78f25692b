/// @file kernel_parity.h
/// @brief Parity of the single-source kernels: one kernel function evaluated on thousands of
///        inputs by C++ (core/kernels/kernels.h) and by an OpenGL compute shader built from the
///        embedded library text (core/kernels/source.h), compared word by word.
///
/// A case is a table row: the GLSL call, the C++ call, an input generator and a tolerance.
/// Argument and result types are deduced from the generator's tuple and the C++ call; each type
/// maps to GLSL through GlslType<T> (scalars, glm vectors and float arrays here; kernel structs
/// in the test that needs them). The shader is "#version 430\n" + kern::glslLibrary() + a main()
/// that reads a0, a1, ... from buffer 0, runs the call and writes r to buffer 1.
///
/// @code
///   cases.push_back(kernelCase("phaseHG", "phaseHG(a0, a1)",
///       [](float c, float g) { return kern::phaseHG(c, g); },
///       [](Draw& d) { return std::tuple(d.f(-1.0f, 1.0f, {-1.0f, 1.0f}), d.f(-0.99f, 0.99f)); },
///       Tolerance{.ulps = 4}));
/// @endcode
/// Integer and bool words must match bit for bit; float words within Tolerance::ulps, or within
/// abs + rel |C++ value| where a case states why (Tolerance::why).
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <random>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/kernels/kernels.h"

namespace nimbus::parity {

/// How a 32-bit word is read and compared.
enum class Word { Float, Uint, Int, Bool };

/// One word of a value: its GLSL accessor after the variable name ("", ".x", ".center.y",
/// "[3]") and its kind.
struct Field {
    std::string access;
    Word kind;
};

/// GLSL name, words and C++ packing of a type. Specialise for each type a kernel takes or
/// returns: type(), fields() and put() (the C++ value as fields().size() words).
template <class T> struct GlslType;

template <> struct GlslType<float> {
    static std::string type() { return "float"; }
    static std::vector<Field> fields() { return {{"", Word::Float}}; }
    static void put(float v, std::uint32_t* w) { w[0] = std::bit_cast<std::uint32_t>(v); }
};
template <> struct GlslType<std::uint32_t> {
    static std::string type() { return "uint"; }
    static std::vector<Field> fields() { return {{"", Word::Uint}}; }
    static void put(std::uint32_t v, std::uint32_t* w) { w[0] = v; }
};
template <> struct GlslType<int> {
    static std::string type() { return "int"; }
    static std::vector<Field> fields() { return {{"", Word::Int}}; }
    static void put(int v, std::uint32_t* w) { w[0] = std::bit_cast<std::uint32_t>(v); }
};
template <> struct GlslType<bool> {
    static std::string type() { return "bool"; }
    static std::vector<Field> fields() { return {{"", Word::Bool}}; }
    static void put(bool v, std::uint32_t* w) { w[0] = v ? 1u : 0u; }
};

/// glm vectors: vec2/3/4, uvec2/3/4, ivec2/3/4.
template <int N, class S> struct GlslType<glm::vec<N, S, glm::defaultp>> {
    using V = glm::vec<N, S, glm::defaultp>;
    static std::string type() {
        const char* prefix = std::is_same_v<S, float> ? "" : std::is_same_v<S, int> ? "i" : "u";
        return std::string(prefix) + "vec" + std::to_string(N);
    }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (int i = 0; i < N; ++i)
            for (const Field& s : GlslType<S>::fields())
                f.push_back({std::string(".") + "xyzw"[i] + s.access, s.kind});
        return f;
    }
    static void put(const V& v, std::uint32_t* w) {
        for (int i = 0; i < N; ++i) GlslType<S>::put(v[i], w + i);
    }
};

/// Several outputs of one call (a void kernel's out parameters, a struct's fields): float[N].
template <std::size_t N> struct GlslType<std::array<float, N>> {
    static std::string type() { return "float[" + std::to_string(N) + "]"; }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (std::size_t i = 0; i < N; ++i)
            f.push_back({"[" + std::to_string(i) + "]", Word::Float});
        return f;
    }
    static void put(const std::array<float, N>& v, std::uint32_t* w) {
        for (std::size_t i = 0; i < N; ++i) w[i] = std::bit_cast<std::uint32_t>(v[i]);
    }
};

/// Input draws for a case: uniform ranges mixed with edge values, reproducible per case.
class Draw {
  public:
    explicit Draw(std::uint64_t seed) : rng_(seed) {}

    float uniform(float lo, float hi) {
        return std::uniform_real_distribution<float>(lo, hi)(rng_);
    }
    /// One of @p edges with probability 1/4 (when given), else uniform in [lo, hi].
    float f(float lo, float hi, std::initializer_list<float> edges = {}) {
        if (edges.size() && chance(0.25f)) return pick(edges);
        return uniform(lo, hi);
    }
    /// Magnitude log-uniform in [lo, hi] (0 < lo < hi), random sign when @p anySign.
    float logUniform(float lo, float hi, bool anySign = false) {
        const float m = std::exp(uniform(std::log(lo), std::log(hi)));
        return anySign && chance(0.5f) ? -m : m;
    }
    /// One of @p edges with probability 1/4 (when given), else uniform in [lo, hi].
    int i(int lo, int hi, std::initializer_list<int> edges = {}) {
        if (edges.size() && chance(0.25f)) return pick(edges);
        return std::uniform_int_distribution<int>(lo, hi)(rng_);
    }
    /// Any 32-bit value, or one of @p edges with probability 1/4.
    std::uint32_t u(std::initializer_list<std::uint32_t> edges = {}) {
        if (edges.size() && chance(0.25f)) return pick(edges);
        return std::uint32_t(rng_());
    }
    glm::vec3 v3(float lo, float hi, std::initializer_list<float> edges = {}) {
        const float x = f(lo, hi, edges), y = f(lo, hi, edges);
        return glm::vec3(x, y, f(lo, hi, edges));
    }
    /// Uniform on the unit sphere, or an axis (±x, ±y, ±z) with probability 1/4.
    glm::vec3 unitVector() {
        if (chance(0.25f)) {
            glm::vec3 a(0.0f);
            a[i(0, 2)] = chance(0.5f) ? 1.0f : -1.0f;
            return a;
        }
        const float z = uniform(-1.0f, 1.0f), phi = uniform(0.0f, 6.2831853f);
        const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
        return glm::normalize(glm::vec3(s * std::cos(phi), s * std::sin(phi), z));
    }
    bool chance(float p) { return uniform(0.0f, 1.0f) < p; }
    template <class T> T pick(std::initializer_list<T> values) {
        const std::size_t k =
            std::uniform_int_distribution<std::size_t>(0, values.size() - 1)(rng_);
        return *(values.begin() + k);
    }

  private:
    std::mt19937_64 rng_;
};

/// Pass rule for float words: |GLSL - C++| <= ulps ulp(C++) + abs + rel |C++| + the case's
/// allowance for that input (see kernelBlock); the parts add up, as errors do. A case that sets
/// rel, abs or an allowance says why in @p why (printed with every failure).
struct Tolerance {
    std::int64_t ulps = 4;
    float rel = 0.0f;
    float abs = 0.0f;
    std::string why;
};

/// One table row, type-erased (build it with kernelCase or kernelBlock).
struct KernelCase {
    std::string name;                          ///< test name: kernel, or kernel_variant
    std::string resultType;                    ///< GLSL type of r
    std::string body;                          ///< GLSL statements computing r from a0, a1, ...
    std::vector<std::string> argTypes;         ///< GLSL types of a0, a1, ...
    std::vector<std::vector<Field>> argFields; ///< their words
    std::vector<Field> resultFields;           ///< the words of r
    int count = 4096;                          ///< number of inputs
    Tolerance tolerance;
    /// Draws @p count inputs from @p seed into @p in, evaluates the C++ side into @p out and
    /// the absolute allowance of every result word into @p allow.
    std::function<void(int count, std::uint64_t seed, std::vector<std::uint32_t>& in,
                       std::vector<std::uint32_t>& out, std::vector<float>& allow)>
        evaluate;

    std::size_t inWords() const {
        std::size_t n = 0;
        for (const auto& f : argFields) n += f.size();
        return n;
    }
};

/// The default allowance: none beyond the Tolerance.
struct NoAllowance {
    template <class... A> float operator()(const A&...) const { return 0.0f; }
};

namespace detail {
template <class Tuple, std::size_t... I>
void putArgs(const Tuple& t, std::uint32_t* w, std::index_sequence<I...>) {
    ((GlslType<std::tuple_element_t<I, Tuple>>::put(std::get<I>(t), w),
      w += GlslType<std::tuple_element_t<I, Tuple>>::fields().size()),
     ...);
    (void)w; // a kernel without arguments
}
template <class... A>
void describeArgs(std::tuple<A...>*, std::vector<std::string>& types,
                  std::vector<std::vector<Field>>& fields) {
    (types.push_back(GlslType<A>::type()), ...);
    (fields.push_back(GlslType<A>::fields()), ...);
}
} // namespace detail

/// A row whose GLSL side is the statements @p glslBody assigning r (e.g. for a kernel with out
/// parameters). @p cpp takes the generator's tuple elements and returns the value r must equal.
/// @p allow (optional) takes the same arguments and returns the absolute error the GLSL side
/// may add for that input (a float for every word, or a value of the result's type for each
/// word): for error propagated from llvmpipe's transcendentals through a kernel's formula.
template <class Cpp, class Gen, class Allow = NoAllowance>
KernelCase kernelBlock(std::string name, std::string glslBody, Cpp cpp, Gen gen,
                       Tolerance tolerance = {}, Allow allow = {}, int count = 4096) {
    using Args = decltype(gen(std::declval<Draw&>()));
    using Result = std::decay_t<decltype(std::apply(cpp, std::declval<Args>()))>;
    using Allowed = std::decay_t<decltype(std::apply(allow, std::declval<Args>()))>;
    static_assert(std::is_same_v<Allowed, float> || std::is_same_v<Allowed, Result>,
                  "an allowance is a float or a value of the result's type");
    KernelCase c;
    c.name = std::move(name);
    c.resultType = GlslType<Result>::type();
    c.body = std::move(glslBody);
    detail::describeArgs(static_cast<Args*>(nullptr), c.argTypes, c.argFields);
    c.resultFields = GlslType<Result>::fields();
    c.count = count;
    c.tolerance = std::move(tolerance);
    const std::size_t inWords = c.inWords(), outWords = c.resultFields.size();
    c.evaluate = [cpp, gen, allow, inWords,
                  outWords](int n, std::uint64_t seed, std::vector<std::uint32_t>& in,
                            std::vector<std::uint32_t>& out, std::vector<float>& allowed) {
        Draw draw(seed);
        in.assign(std::size_t(n) * inWords, 0u);
        out.assign(std::size_t(n) * outWords, 0u);
        allowed.assign(std::size_t(n) * outWords, 0.0f);
        std::vector<std::uint32_t> words(outWords);
        for (int i = 0; i < n; ++i) {
            const Args args = gen(draw);
            detail::putArgs(args, in.data() + std::size_t(i) * inWords,
                            std::make_index_sequence<std::tuple_size_v<Args>>());
            GlslType<Result>::put(std::apply(cpp, args), out.data() + std::size_t(i) * outWords);
            const Allowed a = std::apply(allow, args);
            float* dst = allowed.data() + std::size_t(i) * outWords;
            if constexpr (std::is_same_v<Allowed, float>) {
                std::fill(dst, dst + outWords, a);
            } else {
                GlslType<Result>::put(a, words.data());
                for (std::size_t k = 0; k < outWords; ++k) dst[k] = std::bit_cast<float>(words[k]);
            }
        }
    };
    return c;
}

/// A row whose GLSL side is the expression @p glslCall over a0, a1, ...
template <class Cpp, class Gen, class Allow = NoAllowance>
KernelCase kernelCase(std::string name, const std::string& glslCall, Cpp cpp, Gen gen,
                      Tolerance tolerance = {}, Allow allow = {}, int count = 4096) {
    return kernelBlock(std::move(name), "r = " + glslCall + ";", std::move(cpp), std::move(gen),
                       std::move(tolerance), std::move(allow), count);
}

/// The outcome of one case.
struct ParityResult {
    bool ran = false;          ///< false: the shader did not compile or GL failed (see error)
    std::string error;         ///< compile log or GL error
    int count = 0;             ///< inputs evaluated
    std::int64_t worstUlp = 0; ///< over every float word of every input
    double worstAbs = 0.0;     ///< |GLSL - C++| at its largest
    /// The largest share of the tolerance used by a float word (<= 1 passes).
    double worstShare = 0.0;
    int failures = 0;         ///< inputs outside the tolerance
    std::string worstFailure; ///< the failing input with the largest error, its words
};

/// The compute shader of a case (for reading and for error messages).
std::string paritySource(const KernelCase& c);

/// Runs @p c on the current GL context and compares. Needs a current gl::ComputeContext.
ParityResult runParity(const KernelCase& c);

/// Distance in units in the last place between two floats given as bits (0 for +0 and -0;
/// two NaNs are equal, a NaN and a number are infinitely far).
std::int64_t ulpDistance(std::uint32_t a, std::uint32_t b);

} // namespace nimbus::parity
