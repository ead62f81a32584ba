//! The byte level of checkpoints: little-endian writer and bounds-checked reader, CRC-32,
//! section names, and the atomic file write.

use std::io::Write;
use std::path::Path;

use glam::Vec3;

use super::CheckpointError;

/// Writes `bytes` to `path` atomically: to `path.tmp`, synced, renamed over `path`, and the
/// directory synced, so that `path` is either the old file or the complete new one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = path.with_file_name(name);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)?;
        sync_dir(path);
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Syncs the directory holding `path` so a rename in it is durable (best effort; a no-op
/// where directories cannot be opened).
pub fn sync_dir(path: &Path) {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// CRC-32 tables for slicing-by-8: `CRC_TABLES[0]` is the classic byte table, table `k`
/// advances a byte through `k` more zero bytes.
const CRC_TABLES: [[u32; 256]; 8] = {
    let mut t = [[0u32; 256]; 8];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut i = 0;
    while i < 256 {
        let mut k = 1;
        while k < 8 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xff) as usize];
            k += 1;
        }
        i += 1;
    }
    t
};

/// CRC-32 (IEEE 802.3, the one of zip and PNG) of `bytes`, eight bytes at a time.
pub fn crc32(bytes: &[u8]) -> u32 {
    let t = &CRC_TABLES;
    let mut c = !0u32;
    let mut chunks = bytes.chunks_exact(8);
    for b in &mut chunks {
        let lo = c ^ u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let hi = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        c = t[7][(lo & 0xff) as usize]
            ^ t[6][((lo >> 8) & 0xff) as usize]
            ^ t[5][((lo >> 16) & 0xff) as usize]
            ^ t[4][(lo >> 24) as usize]
            ^ t[3][(hi & 0xff) as usize]
            ^ t[2][((hi >> 8) & 0xff) as usize]
            ^ t[1][((hi >> 16) & 0xff) as usize]
            ^ t[0][(hi >> 24) as usize];
    }
    for &b in chunks.remainder() {
        c = t[0][((c ^ b as u32) & 0xff) as usize] ^ (c >> 8);
    }
    !c
}

pub(super) fn need<'a>(r: Option<Reader<'a>>, tag: &str) -> Result<Reader<'a>, CheckpointError> {
    r.ok_or_else(|| CheckpointError::Malformed(format!("the `{tag}` section is missing")))
}

pub(super) fn tag_str(tag: &[u8; 4]) -> &'static str {
    match tag {
        b"SCEN" => "SCEN section",
        b"META" => "META section",
        b"BODY" => "BODY section",
        b"RBLD" => "RBLD section",
        b"CONT" => "CONT section",
        b"MESH" => "MESH section",
        b"PIEC" => "PIEC section",
        _ => "section",
    }
}

pub(super) fn tag_name(tag: &[u8; 4]) -> String {
    tag.iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                b as char
            } else {
                '?'
            }
        })
        .collect()
}

pub(super) struct Writer {
    pub(super) buf: Vec<u8>,
}

impl Writer {
    pub(super) fn with_capacity(n: usize) -> Self {
        Self {
            buf: Vec::with_capacity(n),
        }
    }
    pub(super) fn u32(&mut self, v: u32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(super) fn u64(&mut self, v: u64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(super) fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    pub(super) fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    pub(super) fn dvec3(&mut self, v: glam::DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
    pub(super) fn vec3(&mut self, v: Vec3) {
        self.f32(v.x);
        self.f32(v.y);
        self.f32(v.z);
    }
    pub(super) fn string(&mut self, s: &str) {
        self.u64(s.len() as u64);
        self.buf.extend_from_slice(s.as_bytes());
    }
    pub(super) fn section(&mut self, tag: &[u8; 4], body: impl FnOnce(&mut Writer)) {
        self.buf.extend_from_slice(tag);
        let at = self.buf.len();
        self.u64(0);
        body(self);
        let len = (self.buf.len() - at - 8) as u64;
        self.buf[at..at + 8].copy_from_slice(&len.to_le_bytes());
    }
}

/// Bounds-checked reading: every length is checked against the bytes left before anything
/// is allocated, so hostile input cannot make the reader allocate more than the file's size.
pub(super) struct Reader<'a> {
    pub(super) buf: &'a [u8],
    pub(super) pos: usize,
    pub(super) what: &'static str,
}

impl<'a> Reader<'a> {
    pub(super) fn need(&self, n: usize) -> Result<(), CheckpointError> {
        if n > self.buf.len() - self.pos {
            return Err(CheckpointError::Malformed(format!(
                "{} ends early ({} bytes left, {n} needed)",
                self.what,
                self.buf.len() - self.pos
            )));
        }
        Ok(())
    }
    pub(super) fn bytes(&mut self, n: u64) -> Result<&'a [u8], CheckpointError> {
        let n = usize::try_from(n).map_err(|_| {
            CheckpointError::Malformed(format!("length {n} in the {} is too large", self.what))
        })?;
        self.need(n)?;
        let out = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }
    pub(super) fn array<const N: usize>(&mut self) -> Result<[u8; N], CheckpointError> {
        Ok(self.bytes(N as u64)?.try_into().expect("N bytes"))
    }
    pub(super) fn u32(&mut self) -> Result<u32, CheckpointError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    pub(super) fn u64(&mut self) -> Result<u64, CheckpointError> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    pub(super) fn len_u64(&mut self) -> Result<u64, CheckpointError> {
        self.u64()
    }
    pub(super) fn f32(&mut self) -> Result<f32, CheckpointError> {
        Ok(f32::from_bits(self.u32()?))
    }
    pub(super) fn f64(&mut self) -> Result<f64, CheckpointError> {
        Ok(f64::from_bits(self.u64()?))
    }
    pub(super) fn dvec3(&mut self) -> Result<glam::DVec3, CheckpointError> {
        Ok(glam::DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
    pub(super) fn dvec3s(&mut self, n: usize) -> Result<Vec<glam::DVec3>, CheckpointError> {
        (0..n).map(|_| self.dvec3()).collect()
    }
    pub(super) fn vec3(&mut self) -> Result<Vec3, CheckpointError> {
        Ok(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }
    /// A count of items of `size` bytes each, checked against the bytes left.
    pub(super) fn count(&mut self, size: usize) -> Result<usize, CheckpointError> {
        let n = self.u64()?;
        let left = (self.buf.len() - self.pos) as u64;
        if n.checked_mul(size as u64).is_none_or(|b| b > left) {
            return Err(CheckpointError::Malformed(format!(
                "count {n} in the {} exceeds the bytes left ({left})",
                self.what
            )));
        }
        Ok(n as usize)
    }
    pub(super) fn string(&mut self) -> Result<String, CheckpointError> {
        let n = self.count(1)?;
        let b = self.bytes(n as u64)?;
        String::from_utf8(b.to_vec()).map_err(|_| {
            CheckpointError::Malformed(format!("a string in the {} is not UTF-8", self.what))
        })
    }
    pub(super) fn finish(&self) -> Result<(), CheckpointError> {
        if self.pos != self.buf.len() {
            return Err(CheckpointError::Malformed(format!(
                "{} bytes left over at the end of the {}",
                self.buf.len() - self.pos,
                self.what
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::crc32;

    #[test]
    pub(super) fn crc32_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        // Against the bit-at-a-time definition, on every length and alignment up to 64.
        let data: Vec<u8> = (0..200u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for start in 0..8 {
            for len in 0..64 {
                let bytes = &data[start..start + len];
                let mut c = !0u32;
                for &b in bytes {
                    c ^= b as u32;
                    for _ in 0..8 {
                        c = if c & 1 != 0 {
                            0xEDB8_8320 ^ (c >> 1)
                        } else {
                            c >> 1
                        };
                    }
                }
                assert_eq!(crc32(bytes), !c, "start {start} len {len}");
            }
        }
    }
}
