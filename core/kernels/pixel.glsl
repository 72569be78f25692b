// pixel.glsl: pixel reconstruction filters (values = the PixelFilter enum of core/scene.h).
// Separable, over offsets d from the pixel centre in pixels, zero beyond half the width.

const int FILTER_BOX = 0;
const int FILTER_GAUSSIAN = 1;        // exp(-x^2 / 2 s^2) - exp(-r^2 / 2 s^2), s = r / 3
const int FILTER_BLACKMAN_HARRIS = 2; // the 4-term Blackman-Harris window over [-r, r]

NB_FN float pixelFilter1D(int kind, float x, float radius) {
    if (abs(x) > radius) return 0.0f;
    if (kind == FILTER_GAUSSIAN) {
        float s = radius / 3.0f;
        return max(0.0f, exp(-x * x / (2.0f * s * s)) - exp(-radius * radius / (2.0f * s * s)));
    }
    if (kind == FILTER_BLACKMAN_HARRIS) {
        float t = 6.28318530718f * (x + radius) / (2.0f * radius);
        return max(0.0f, 0.35875f - 0.48829f * cos(t) + 0.14128f * cos(2.0f * t) -
                             0.01168f * cos(3.0f * t));
    }
    return 1.0f;
}

// Weight of a sample at offset (dx, dy) from the pixel centre for a filter `width` pixels wide.
NB_FN float pixelFilterWeight(int kind, float dx, float dy, float width) {
    float r = 0.5f * width;
    return pixelFilter1D(kind, dx, r) * pixelFilter1D(kind, dy, r);
}

// Offset from the pixel centre of sample k of n, stratified on a grid of ceil(sqrt(n)) columns
// and jittered by u in [0, 1)^2 within its cell, spread over the filter's width.
NB_FN vec2 pixelSampleOffset(int k, int n, float ux, float uy, float width) {
    int cols = int(ceil(sqrt(float(n))));
    int rows = (n + cols - 1) / cols;
    float sx = (float(k % cols) + ux) / float(cols);
    float sy = (float(k / cols) + uy) / float(rows);
    return vec2((sx - 0.5f) * width, (sy - 0.5f) * width);
}
