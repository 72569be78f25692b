// prelude.glsl: GLSL side of the single-source kernels (see prelude.h for the C++ side).
// The shader assembler puts "#version 430" before this file.
#define IN(T) in T
#define OUT(T) out T
#define INOUT(T) inout T
#define NB_FN
