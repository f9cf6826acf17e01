//! Section sizes of the firmware's ELF (32-bit little-endian ARM), read
//! from the section headers, so that no binutils are needed.

use std::path::Path;

/// Sizes of the sections the memory budget is made of, bytes.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    /// `.vector_table` (flash).
    pub vector_table: u64,
    /// `.text` (flash).
    pub text: u64,
    /// `.rodata` (flash).
    pub rodata: u64,
    /// `.data` (RAM, initial values in flash).
    pub data: u64,
    /// `.bss` (RAM).
    pub bss: u64,
    /// `.uninit` (RAM).
    pub uninit: u64,
}

impl Sizes {
    /// Flash used: vector table, code, read-only data and `.data`'s image.
    pub fn flash(&self) -> u64 {
        self.vector_table + self.text + self.rodata + self.data
    }

    /// Static RAM (the stack gets the rest).
    pub fn static_ram(&self) -> u64 {
        self.data + self.bss + self.uninit
    }
}

fn u16_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?)))
}

fn u32_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?)))
}

/// Reads the section sizes of `path`.
pub fn sizes(path: &Path) -> Result<Sizes, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    parse(&bytes).ok_or_else(|| format!("{} is not a 32-bit little-endian ELF", path.display()))
}

fn parse(b: &[u8]) -> Option<Sizes> {
    // ELF32 header: magic, class 1 (32-bit), data 1 (little endian).
    if b.get(0..4)? != b"\x7fELF" || *b.get(4)? != 1 || *b.get(5)? != 1 {
        return None;
    }
    let shoff = u32_at(b, 0x20)? as usize;
    let shentsize = u16_at(b, 0x2E)? as usize;
    let shnum = u16_at(b, 0x30)? as usize;
    let shstrndx = u16_at(b, 0x32)? as usize;
    let header = |i: usize| shoff + i * shentsize;
    let strtab = u32_at(b, header(shstrndx) + 0x10)? as usize;
    let mut sizes = Sizes::default();
    for i in 0..shnum {
        let h = header(i);
        let name_at = strtab + u32_at(b, h)? as usize;
        let name_len = b.get(name_at..)?.iter().position(|&c| c == 0)?;
        let name = std::str::from_utf8(&b[name_at..name_at + name_len]).ok()?;
        let size = u32_at(b, h + 0x14)?;
        match name {
            ".vector_table" => sizes.vector_table = size,
            ".text" => sizes.text = size,
            ".rodata" => sizes.rodata = size,
            ".data" => sizes.data = size,
            ".bss" => sizes.bss = size,
            ".uninit" => sizes.uninit = size,
            _ => {}
        }
    }
    Some(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32 with a string table and two sections, built by hand.
    #[test]
    fn reads_section_sizes() {
        let names = b"\0.text\0.bss\0.shstrtab\0";
        let mut b = vec![0u8; 0x34];
        b[0..4].copy_from_slice(b"\x7fELF");
        b[4] = 1;
        b[5] = 1;
        let strtab_at = b.len();
        b.extend_from_slice(names);
        let shoff = b.len();
        let section = |name: u32, offset: u32, size: u32| {
            let mut h = vec![0u8; 40];
            h[0..4].copy_from_slice(&name.to_le_bytes());
            h[0x10..0x14].copy_from_slice(&offset.to_le_bytes());
            h[0x14..0x18].copy_from_slice(&size.to_le_bytes());
            h
        };
        b.extend(section(0, 0, 0));
        b.extend(section(1, 0, 1234));
        b.extend(section(7, 0, 567));
        b.extend(section(12, strtab_at as u32, names.len() as u32));
        b[0x20..0x24].copy_from_slice(&(shoff as u32).to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        b[0x30..0x32].copy_from_slice(&4u16.to_le_bytes());
        b[0x32..0x34].copy_from_slice(&3u16.to_le_bytes());
        let s = parse(&b).unwrap();
        assert_eq!((s.text, s.bss, s.data), (1234, 567, 0));
        assert_eq!(parse(b"not an elf"), None);
        assert_eq!(parse(&b[..0x40]), None, "truncated");
    }
}
