//! Device buffers that are rewritten in place while their contents fit and remade, with
//! headroom, only when the contents outgrow them. The coupled step's per-step tables (ghosts,
//! thin-wall taps, the hand-over's particles) and its staging buffers use them, so that a step
//! of a running coupled scene makes no buffer on the device ([`GrowingBuffer::made`] counts the
//! ones made: the coupled tests assert that the steady state makes none).

/// Smallest size (bytes) of a growing buffer: an empty table still needs a binding.
const MIN_BYTES: u64 = 256;

/// A buffer whose contents are rewritten each use, with room to spare.
pub struct GrowingBuffer {
    buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
    /// Buffers made so far (the first one included).
    made: u64,
}

/// Room for `bytes` with half again to spare, in whole 256-byte blocks.
fn room_for(bytes: u64) -> u64 {
    (bytes + bytes / 2).max(MIN_BYTES).next_multiple_of(256)
}

impl GrowingBuffer {
    /// An empty buffer with room for `bytes`.
    pub fn with_room(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages, bytes: u64) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: room_for(bytes), usage, mapped_at_creation: false });
        GrowingBuffer { buffer, label, usage, made: 1 }
    }

    /// A storage buffer holding `data` (with room to spare; readable as a copy source and
    /// writable by the queue), filled as it is made.
    pub fn storage(device: &wgpu::Device, label: &'static str, data: &[u8]) -> Self {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: room_for(data.len() as u64), usage, mapped_at_creation: true });
        buffer.get_mapped_range_mut(..).slice(..data.len()).copy_from_slice(data);
        buffer.unmap();
        GrowingBuffer { buffer, label, usage, made: 1 }
    }

    /// The buffer as it is now (a bind group holding it must be remade when [`Self::write`] or
    /// [`Self::reserve`] says a new one was made).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Buffers this one has made, the first included: more than one means its contents
    /// outgrew it that many times less one.
    pub fn made(&self) -> u64 {
        self.made
    }

    /// Makes room for `bytes`: true when a new (empty) buffer had to be made, so that bind
    /// groups that hold the old one must be made again.
    pub fn reserve(&mut self, device: &wgpu::Device, bytes: u64) -> bool {
        if bytes <= self.buffer.size() {
            return false;
        }
        self.buffer =
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(self.label), size: room_for(bytes), usage: self.usage, mapped_at_creation: false });
        self.made += 1;
        true
    }

    /// Writes `data` (a multiple of 4 bytes) at the start of the buffer through the queue, the
    /// rest left as it was: true when a new buffer had to be made for it (see [`Self::reserve`]).
    pub fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) -> bool {
        let remade = self.reserve(device, data.len() as u64);
        if !data.is_empty() {
            queue.write_buffer(&self.buffer, 0, data);
        }
        remade
    }
}

/// A staging buffer kept for reads of whole buffers (made at the first read, grown when a read
/// needs more): the coupled step's read of the particles makes no buffer.
#[derive(Default)]
pub struct Readback {
    staging: std::sync::Mutex<Option<GrowingBuffer>>,
}

impl Readback {
    /// Each of `buffers` whole, read in one trip (one submission, one wait), or None when the
    /// read fails.
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue, buffers: &[&wgpu::Buffer]) -> Option<Vec<Vec<u8>>> {
        let parts: Vec<(&wgpu::Buffer, u64, u64)> = buffers.iter().map(|b| (*b, 0, b.size())).collect();
        let all = self.read_parts(device, queue, &parts)?;
        Some(super::context::split_read(&all, buffers.iter().map(|b| b.size())))
    }

    /// Makes the staging buffer (or grows it) with room for reads of up to `bytes`, so that
    /// those make none: a reader whose reads vary in size (the gather's node lists) sizes it
    /// with its own buffers.
    pub fn reserve(&self, device: &wgpu::Device, bytes: u64) {
        let mut guard = self.staging.lock().expect("the staging buffer's lock");
        guard
            .get_or_insert_with(|| GrowingBuffer::with_room(device, "readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, bytes))
            .reserve(device, bytes);
    }

    /// The byte ranges (buffer, offset, length; multiples of 4) one after the other, read in
    /// one trip, or None when the read fails.
    pub fn read_parts(&self, device: &wgpu::Device, queue: &wgpu::Queue, parts: &[(&wgpu::Buffer, u64, u64)]) -> Option<Vec<u8>> {
        let total: u64 = parts.iter().map(|p| p.2).sum();
        let mut guard = self.staging.lock().expect("the staging buffer's lock");
        let staging =
            guard.get_or_insert_with(|| GrowingBuffer::with_room(device, "readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, total));
        staging.reserve(device, total);
        super::context::try_read_parts_into(device, queue, device.create_command_encoder(&Default::default()), parts, staging.buffer())
    }

    /// Staging buffers made so far.
    pub fn made(&self) -> u64 {
        self.staging.lock().expect("the staging buffer's lock").as_ref().map_or(0, GrowingBuffer::made)
    }
}

/// A bind group over whole buffers, kept while they are the same buffers and made again when
/// one of them is another (a [`GrowingBuffer`] that outgrew its room): the coupled step's
/// kernels bind their growing buffers through it, so that a step that outgrows nothing makes none.
#[derive(Default)]
pub struct KeptBindGroup {
    group: Option<(wgpu::BindGroup, Vec<wgpu::Buffer>)>,
    /// Bind groups made so far.
    made: u64,
}

impl KeptBindGroup {
    /// The bind group of `layout` with buffer k at binding k, made again only when `bound`
    /// differs from the buffers it was made with.
    pub fn over(&mut self, device: &wgpu::Device, layout: &wgpu::BindGroupLayout, label: &'static str, bound: &[wgpu::Buffer]) -> &wgpu::BindGroup {
        if self.group.as_ref().is_none_or(|(_, was)| was.as_slice() != bound) {
            let entries: Vec<wgpu::BindGroupEntry> =
                bound.iter().enumerate().map(|(k, buf)| wgpu::BindGroupEntry { binding: k as u32, resource: buf.as_entire_binding() }).collect();
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries });
            self.group = Some((group, bound.to_vec()));
            self.made += 1;
        }
        &self.group.as_ref().expect("made above").0
    }

    /// Bind groups made so far.
    pub fn made(&self) -> u64 {
        self.made
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A buffer made for n bytes takes later contents of up to 1.5 n without a new buffer (the
    /// coupled tables change size by a few per cent a step), in whole 256-byte blocks, and an
    /// empty table still gets a binding's worth.
    #[test]
    fn a_buffer_has_half_again_the_room_of_its_contents() {
        assert_eq!(room_for(0), MIN_BYTES);
        for n in [4u64, 255, 256, 1000, 4096, 123_456, 10_000_000] {
            let room = room_for(n);
            assert!(room >= n + n / 2 && room.is_multiple_of(256) && room < n + n / 2 + 256 + MIN_BYTES, "{n} bytes: room {room}");
        }
    }
}
