// The patch pass's round schedule on the GPU (patch_pass.wgsl): before each round, the
// workgroup counts of its thirteen dispatches, copied from the full counts while the wavefront
// has patches pending and nothing has stopped the submission, else zero, so a settled
// wavefront's remaining rounds dispatch nothing. Read as indirect dispatch arguments.

// Unused: the layout's uniform (the patch pass's parameters).
@group(0) @binding(0) var<uniform> unused: vec4<u32>;
// The patch pass's state (patch_pass.wgsl): word 1 pending patches, word 4 stalled.
@group(0) @binding(1) var<storage, read_write> state: array<u32>;
// The round's full workgroup counts (x, y, z per dispatch), then the live ones.
@group(0) @binding(2) var<storage, read_write> args: array<u32>;

const ROUND_ARGS: u32 = 39u;

@compute @workgroup_size(1)
fn schedule() {
    let on = state[4] == 0u && state[1] != 0u;
    for (var i = 0u; i < ROUND_ARGS; i++) {
        args[ROUND_ARGS + i] = select(0u, args[i], on);
    }
}
