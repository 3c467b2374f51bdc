//! Reading the resolved sample counts back: map the readback buffer, wait for the GPU (the
//! blocking read Seletsky 2013, section 4.3.2 accepts, at the end of the frame), and store each
//! count as its query's [`QueryOutcome::Samples`].

use std::sync::mpsc;

use wgpu::Device;

use super::types::QueryOutcome;
use crate::device::GpuError;

/// Maps the first `result_bytes` of `readback` (of `MAP_READ` usage, its copy already
/// submitted), waits for it, and writes query `i`'s sample count into
/// `outcomes[query_slots[i]]`. The buffer is unmapped again before returning.
pub(super) fn read_samples(
    device: &Device,
    readback: &wgpu::Buffer,
    result_bytes: u64,
    query_slots: &[usize],
    outcomes: &mut [(u32, QueryOutcome)],
) -> Result<(), GpuError> {
    let slice = readback.slice(..result_bytes);
    let (tx, rx) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        // The receiver waits below; if it is gone there is nobody to tell.
        let _ = tx.send(r);
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(GpuError::Readback(e.to_string())),
        Err(e) => return Err(GpuError::Readback(e.to_string())),
    }
    let mapped = slice.get_mapped_range().map(|view| {
        // Resolved occlusion results are native-endian u64 sample counts. Read them bytewise
        // rather than casting: the mapped pointer's alignment is not promised to be 8.
        for (&slot, bytes) in query_slots.iter().zip(view.chunks_exact(8)) {
            let mut count = [0u8; 8];
            count.copy_from_slice(bytes);
            if let Some((_, outcome)) = outcomes.get_mut(slot) {
                *outcome = QueryOutcome::Samples(u64::from_ne_bytes(count));
            }
        }
    });
    readback.unmap();
    mapped.map_err(|e| GpuError::Readback(e.to_string()))
}
