//! Buffers beyond what the adapter binds are refused with a clear error naming the sizes, not
//! left to wgpu's validation panic (lavapipe binds 128 MiB per storage buffer, so a 4096² rig's
//! colour output, 256 MiB, does not fit there).

use derma_core::gpu::{context, GpuError};

#[test]
fn oversized_storage_is_refused_with_the_sizes_named() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    let ctx = context().unwrap();
    let l = ctx.device.limits();
    let limit = l.max_storage_buffer_binding_size.min(l.max_buffer_size);
    assert!(ctx.check_storage("a buffer at the limit", limit).is_ok());
    match ctx.check_storage("the test's buffer", limit + 1) {
        Err(e @ GpuError::TooLarge { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("the test's buffer"), "{msg}");
            assert!(msg.contains(&(limit + 1).to_string()), "{msg}");
            assert!(msg.contains(&limit.to_string()), "{msg}");
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
}
