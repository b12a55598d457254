//! A pool of device buffers reused across solves (STYLE: "reuse buffers through a pool keyed by
//! size/usage"): a solve leases what it needs and the lease returns the buffer on drop, so
//! relighting or re-solving a mesh of similar size allocates nothing on the device.

use std::collections::HashMap;
use std::ops::Deref;
use std::sync::Mutex;

/// Buffers kept per (size class, usage) when returned.
const KEEP_PER_KEY: usize = 16;

/// The size class of a request: the size rounded up to 4 significant bits (at most 12.5% waste),
/// at least 256 bytes, a multiple of 16.
#[must_use]
pub(crate) fn size_class(bytes: u64) -> u64 {
    let b = bytes.max(256);
    let shift = (64 - b.leading_zeros()).saturating_sub(4);
    let unit = 1u64 << shift;
    b.div_ceil(unit) * unit
}

/// Free buffers by (size class, usage bits).
#[derive(Default)]
pub(crate) struct BufferPool {
    free: Mutex<HashMap<(u64, u32), Vec<wgpu::Buffer>>>,
    created: Mutex<u64>,
}

impl BufferPool {
    /// A buffer of at least `bytes` with `usage`, reused when one is free.
    pub(crate) fn lease<'p>(
        &'p self,
        device: &wgpu::Device,
        bytes: u64,
        usage: wgpu::BufferUsages,
        label: &'static str,
    ) -> Lease<'p> {
        let key = (size_class(bytes), usage.bits());
        let reused = self.free.lock().unwrap_or_else(|e| e.into_inner()).get_mut(&key).and_then(Vec::pop);
        let buffer = reused.unwrap_or_else(|| {
            *self.created.lock().unwrap_or_else(|e| e.into_inner()) += 1;
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: key.0, usage, mapped_at_creation: false })
        });
        Lease { pool: self, key, buffer: Some(buffer) }
    }

    /// How many buffers the pool has created so far (tests check reuse with it).
    pub(crate) fn created(&self) -> u64 {
        *self.created.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Frees every pooled buffer.
    pub(crate) fn clear(&self) {
        self.free.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    fn give_back(&self, key: (u64, u32), buffer: wgpu::Buffer) {
        let mut free = self.free.lock().unwrap_or_else(|e| e.into_inner());
        let list = free.entry(key).or_default();
        if list.len() < KEEP_PER_KEY {
            list.push(buffer);
        }
    }
}

/// A buffer leased from the pool; returned to it on drop.
pub(crate) struct Lease<'p> {
    pool: &'p BufferPool,
    key: (u64, u32),
    buffer: Option<wgpu::Buffer>,
}

impl Deref for Lease<'_> {
    type Target = wgpu::Buffer;

    fn deref(&self) -> &wgpu::Buffer {
        self.buffer.as_ref().expect("a lease holds its buffer until dropped")
    }
}

impl Drop for Lease<'_> {
    fn drop(&mut self) {
        if let Some(b) = self.buffer.take() {
            self.pool.give_back(self.key, b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::size_class;

    #[test]
    fn size_classes_cover_the_request_with_little_waste() {
        for bytes in [0u64, 1, 255, 256, 257, 1000, 4096, 4097, 1 << 20, (1 << 20) + 1, 123_456_789] {
            let c = size_class(bytes);
            assert!(c >= bytes.max(256) && c.is_multiple_of(16), "{bytes} -> {c}");
            assert!(c as f64 <= bytes.max(256) as f64 * 1.125 + 16.0, "{bytes} -> {c}");
        }
        assert_eq!(size_class(1000), size_class(1010));
    }
}
