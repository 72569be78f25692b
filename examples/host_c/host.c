/*
 * nimbus_host_c: a small C99 host of libnimbus.so. It loads the library with dlopen (no link
 * dependency on it), checks its version, loads a scene, applies overrides, renders one frame
 * into its own buffer and prints the frame's mean RGBA; optionally it writes a PPM preview and
 * the raw float RGBA. Errors are reported through the context's last error.
 *
 *   nimbus_host_c [--lib PATH] SCENE.toml [--set section.key=value]... [--frame N]
 *                 [--ppm OUT.ppm] [--raw OUT.f32] [--quiet]
 *
 * The library is looked for at --lib, else next to this executable (libnimbus.so.0), else
 * wherever the dynamic loader finds libnimbus.so.0. Exit codes are the library's statuses
 * (the `nimbus` command's: 2 bad input, 3 I/O, 4 out of memory, 130 interrupted, 1 internal).
 */
#include <dlfcn.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "nimbus.h"

/* the functions used, looked up by name */
static struct {
    const char* (*version)(void);
    void (*version_numbers)(int*, int*, int*);
    nimbus_context* (*create)(void);
    void (*destroy)(nimbus_context*);
    nimbus_status (*load_file)(nimbus_context*, const char*);
    nimbus_status (*set)(nimbus_context*, const char*);
    nimbus_status (*frames)(nimbus_context*, int*, int, int*);
    nimbus_status (*plan_int)(nimbus_context*, int, nimbus_plan_item, int*);
    nimbus_status (*set_progress)(nimbus_context*, nimbus_progress_fn, void*);
    nimbus_status (*render)(nimbus_context*, int, float*, size_t);
    const char* (*warnings)(nimbus_context*);
    const char* (*status_name)(nimbus_status);
    const char* (*last_error)(const nimbus_context*);
    const char* (*last_error_file)(const nimbus_context*);
    int (*last_error_line)(const nimbus_context*);
} api;

/* dlsym returns an object pointer; copying its bytes into the function pointer is the POSIX way
 * that stays clean under -pedantic */
static int lookup(void* lib, const char* name, void* fn, size_t size) {
    void* sym = dlsym(lib, name);
    if (!sym) {
        fprintf(stderr, "nimbus_host_c: %s not found in the library: %s\n", name, dlerror());
        return 0;
    }
    memcpy(fn, &sym, size);
    return 1;
}
#define LOOKUP(lib, field, name) lookup(lib, name, &api.field, sizeof api.field)

static void* openLibrary(const char* given) {
    char path[PATH_MAX];
    void* lib;
    if (given) {
        lib = dlopen(given, RTLD_NOW | RTLD_LOCAL);
        if (!lib) fprintf(stderr, "nimbus_host_c: cannot load %s: %s\n", given, dlerror());
        return lib;
    }
    /* next to this executable */
    ssize_t n = readlink("/proc/self/exe", path, sizeof path - 1);
    if (n > 0) {
        path[n] = '\0';
        char* slash = strrchr(path, '/');
        if (slash && (size_t)(slash - path) + sizeof "/libnimbus.so.0" <= sizeof path) {
            strcpy(slash, "/libnimbus.so.0");
            lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
            if (lib) return lib;
        }
    }
    lib = dlopen("libnimbus.so.0", RTLD_NOW | RTLD_LOCAL);
    if (!lib) fprintf(stderr, "nimbus_host_c: cannot load libnimbus.so.0: %s\n", dlerror());
    return lib;
}

/* progress: count tiles; cancel never */
static int onProgress(void* user, int done, int total) {
    int* counts = (int*)user;
    counts[0] = done;
    counts[1] = total;
    return 0;
}

/* prints the context's last error as the command would, and returns its status */
static int fail(nimbus_context* ctx, nimbus_status st, const char* what) {
    const char* file = api.last_error_file(ctx);
    fprintf(stderr, "nimbus_host_c: %s failed (%s, status %d): %s\n", what, api.status_name(st),
            (int)st, api.last_error(ctx));
    if (file[0]) fprintf(stderr, "  in %s, line %d\n", file, api.last_error_line(ctx));
    return (int)st;
}

static float toByte(float v) {
    /* a quick look, not colour-managed: clamp and a 2.2 gamma */
    if (!(v > 0.0f)) return 0.0f;
    if (v >= 1.0f) return 255.0f;
    return 255.0f * powf(v, 1.0f / 2.2f) + 0.5f;
}

static int writePpm(const char* path, const float* rgba, int w, int h) {
    FILE* f = fopen(path, "wb");
    if (!f) return 0;
    fprintf(f, "P6\n%d %d\n255\n", w, h);
    for (size_t i = 0; i < (size_t)w * (size_t)h; ++i) {
        unsigned char px[3];
        for (int c = 0; c < 3; ++c) px[c] = (unsigned char)toByte(rgba[4 * i + (size_t)c]);
        fwrite(px, 1, 3, f);
    }
    return fclose(f) == 0;
}

static int writeRaw(const char* path, const float* rgba, size_t count) {
    FILE* f = fopen(path, "wb");
    if (!f) return 0;
    size_t written = fwrite(rgba, sizeof(float), count, f);
    return (fclose(f) == 0) && written == count;
}

int main(int argc, char** argv) {
    const char* libPath = NULL;
    const char* scene = NULL;
    const char* ppm = NULL;
    const char* raw = NULL;
    const char* sets[64];
    int nsets = 0, frame = 0, haveFrame = 0, quiet = 0;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--lib") && i + 1 < argc)
            libPath = argv[++i];
        else if (!strcmp(argv[i], "--set") && i + 1 < argc && nsets < 64)
            sets[nsets++] = argv[++i];
        else if (!strcmp(argv[i], "--frame") && i + 1 < argc) {
            frame = atoi(argv[++i]);
            haveFrame = 1;
        } else if (!strcmp(argv[i], "--ppm") && i + 1 < argc)
            ppm = argv[++i];
        else if (!strcmp(argv[i], "--raw") && i + 1 < argc)
            raw = argv[++i];
        else if (!strcmp(argv[i], "--quiet"))
            quiet = 1;
        else if (argv[i][0] != '-' && !scene)
            scene = argv[i];
        else {
            fprintf(stderr,
                    "usage: %s [--lib PATH] SCENE.toml [--set section.key=value]... "
                    "[--frame N] [--ppm OUT.ppm] [--raw OUT.f32] [--quiet]\n",
                    argv[0]);
            return 2;
        }
    }
    if (!scene) {
        fprintf(stderr, "nimbus_host_c: no scene file given\n");
        return 2;
    }

    void* lib = openLibrary(libPath);
    if (!lib) return 1;
    if (!LOOKUP(lib, version, "nimbus_version") ||
        !LOOKUP(lib, version_numbers, "nimbus_version_numbers") ||
        !LOOKUP(lib, create, "nimbus_create") || !LOOKUP(lib, destroy, "nimbus_destroy") ||
        !LOOKUP(lib, load_file, "nimbus_load_file") || !LOOKUP(lib, set, "nimbus_set") ||
        !LOOKUP(lib, frames, "nimbus_frames") || !LOOKUP(lib, plan_int, "nimbus_plan_int") ||
        !LOOKUP(lib, set_progress, "nimbus_set_progress") ||
        !LOOKUP(lib, render, "nimbus_render") || !LOOKUP(lib, warnings, "nimbus_warnings") ||
        !LOOKUP(lib, status_name, "nimbus_status_name") ||
        !LOOKUP(lib, last_error, "nimbus_last_error") ||
        !LOOKUP(lib, last_error_file, "nimbus_last_error_file") ||
        !LOOKUP(lib, last_error_line, "nimbus_last_error_line"))
        return 1;

    /* the same major version, and at least the header's minor */
    int major = 0, minor = 0, patch = 0;
    api.version_numbers(&major, &minor, &patch);
    if (major != NIMBUS_VERSION_MAJOR || minor < NIMBUS_VERSION_MINOR) {
        fprintf(stderr, "nimbus_host_c: library %s, built for %d.%d.x\n", api.version(),
                NIMBUS_VERSION_MAJOR, NIMBUS_VERSION_MINOR);
        return 1;
    }
    if (!quiet) printf("libnimbus %s\n", api.version());

    nimbus_context* ctx = api.create();
    if (!ctx) {
        fprintf(stderr, "nimbus_host_c: out of memory\n");
        return 4;
    }
    int rc = 0;
    nimbus_status st = api.load_file(ctx, scene);
    if (st != NIMBUS_OK) {
        rc = fail(ctx, st, "loading the scene");
        goto done;
    }
    for (int i = 0; i < nsets; ++i) {
        st = api.set(ctx, sets[i]);
        if (st != NIMBUS_OK) {
            rc = fail(ctx, st, "--set");
            goto done;
        }
    }
    if (!haveFrame) { /* the scene's first frame */
        int count = 0;
        st = api.frames(ctx, &frame, 1, &count);
        if (st != NIMBUS_OK) {
            rc = fail(ctx, st, "reading the frames");
            goto done;
        }
    }
    int w = 0, h = 0;
    if ((st = api.plan_int(ctx, frame, NIMBUS_PLAN_WIDTH, &w)) != NIMBUS_OK ||
        (st = api.plan_int(ctx, frame, NIMBUS_PLAN_HEIGHT, &h)) != NIMBUS_OK) {
        rc = fail(ctx, st, "planning the frame");
        goto done;
    }
    size_t count = (size_t)w * (size_t)h * 4;
    float* rgba = (float*)malloc(count * sizeof(float));
    if (!rgba) {
        fprintf(stderr, "nimbus_host_c: out of memory for %dx%d\n", w, h);
        rc = 4;
        goto done;
    }
    int tiles[2] = {0, 0};
    api.set_progress(ctx, onProgress, tiles);
    st = api.render(ctx, frame, rgba, count);
    const char* warnings = api.warnings(ctx);
    if (warnings && warnings[0]) fputs(warnings, stderr);
    if (st != NIMBUS_OK) {
        rc = fail(ctx, st, "rendering");
        free(rgba);
        goto done;
    }
    double mean[4] = {0.0, 0.0, 0.0, 0.0};
    int finite = 1;
    for (size_t i = 0; i < count; ++i) {
        if (!isfinite(rgba[i])) finite = 0;
        mean[i % 4] += rgba[i];
    }
    for (int c = 0; c < 4; ++c) mean[c] /= (double)w * (double)h;
    printf("frame %d: %dx%d, %d/%d tiles, mean RGBA %.6g %.6g %.6g %.6g\n", frame, w, h, tiles[0],
           tiles[1], mean[0], mean[1], mean[2], mean[3]);
    if (!finite) {
        fprintf(stderr, "nimbus_host_c: non-finite pixels\n");
        rc = 1;
    }
    if (ppm && !writePpm(ppm, rgba, w, h)) {
        fprintf(stderr, "nimbus_host_c: cannot write %s\n", ppm);
        rc = 3;
    }
    if (raw && !writeRaw(raw, rgba, count)) {
        fprintf(stderr, "nimbus_host_c: cannot write %s\n", raw);
        rc = 3;
    }
    free(rgba);
done:
    api.destroy(ctx);
    dlclose(lib);
    return rc;
}
