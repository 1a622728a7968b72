// Work counts (gpu/work.rs): exact integer counts of what a pass does (cone samples, octree
// nodes visited, shadow-ray steps), so its cost can be seen on adapters whose times say little
// (lavapipe) and compared between builds. Compiled in only with `@if(count_work)`, which a
// counting renderer sets; everywhere else `count_work` is empty and the binding does not exist.
//
// A counting pass binds its region of the counters: up to 16 quantities of 64 bits (low word,
// high word), summed over every invocation of the pass in a frame. An invocation accumulates
// its own counts and adds each once, at its end.

@if(count_work) @group(0) @binding(63) var<storage, read_write> work_counts: array<atomic<u32>, 32>;

// Adds `n` to quantity `q` of the bound region: the low word, and one into the high word when
// that add wraps (atomicAdd returns the word before the add, so the carry is exact).
@if(count_work) fn count_work(q: u32, n: u32) {
    if n == 0u {
        return;
    }
    let before = atomicAdd(&work_counts[2u * q], n);
    if before > 0xffffffffu - n {
        atomicAdd(&work_counts[2u * q + 1u], 1u);
    }
}

@if(!count_work) fn count_work(q: u32, n: u32) {}
