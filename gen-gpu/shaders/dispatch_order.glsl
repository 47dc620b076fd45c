// The order a dispatch's workgroups take their work in, shared by gen-gpu's and render's
// kernels (included once: guarded). The CPU port is gen_gpu::dispatch_order; keep the two in
// step (tests compare them).
//
// A CPU device (lavapipe's llvmpipe) splits a dispatch's workgroups, in index order, into one
// contiguous run per worker thread (the first n / T to the first thread, and so on; the
// remainder singly at the end), and each thread runs its run alone. Where the work of a
// workgroup follows the hair or the image (strands on the near side of a head cost more than
// those behind it, hair covers the top of the frame more than the bottom), one thread finishes
// long before the other. With DISPATCH_WORKERS = T > 1, workgroup w takes the work of another
// index, so that each thread's run is a comb over the whole dispatch (every T-th index), each
// starting at its own place: the runs cost about the same, and the threads work far apart (they
// share fewer cache lines). GPUs schedule workgroups dynamically: T = 1 there, and the order is
// the identity, which the compiler folds away.
#ifndef HK_DISPATCH_ORDER_GLSL
#define HK_DISPATCH_ORDER_GLSL

#include "hk_gen_contract.glsl"

// Set by the backend on every compute pipeline (gen_gpu::Context::dispatch_workers).
layout(constant_id = HK_DISPATCH_WORKERS_CONSTANT_ID) const uint DISPATCH_WORKERS = 1u;

// The work index of workgroup w (its linear index, as the device numbers them) of n: a
// permutation of 0 .. n - 1. Thread t of T runs w in [t q, (t + 1) q), q = n / T, which take
// the indices j T + t for j from t q / T on, wrapping around; the remainder keeps its own.
uint dispatch_order(uint w, uint n) {
    uint workers = DISPATCH_WORKERS;
    if (workers <= 1u) {
        return w;
    }
    uint q = n / workers;
    if (q == 0u || w >= workers * q) {
        return w;
    }
    uint t = w / q;
    uint j = w - t * q + t * q / workers;
    j = j >= q ? j - q : j;
    return j * workers + t;
}

// gl_WorkGroupID in the dispatch order: the workgroup whose work this one does.
uvec3 ordered_workgroup_id() {
    uvec3 g = gl_NumWorkGroups;
    uint w = (gl_WorkGroupID.z * g.y + gl_WorkGroupID.y) * g.x + gl_WorkGroupID.x;
    uint o = dispatch_order(w, g.x * g.y * g.z);
    return uvec3(o % g.x, (o / g.x) % g.y, o / (g.x * g.y));
}

// gl_GlobalInvocationID in the dispatch order. A macro: gl_WorkGroupSize may be read only after
// the includer declares its workgroup size, which comes after its includes.
#define ORDERED_GLOBAL_INVOCATION_ID (ordered_workgroup_id() * gl_WorkGroupSize + gl_LocalInvocationID)

#endif
