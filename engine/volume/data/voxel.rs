//! Voxel element types, byte order, and decoding raw bytes to `f32`.

use std::fmt;
use std::str::FromStr;

/// Storage type of one voxel in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VoxelType {
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 32-bit integer (decoded to `f32`, so values above 2^24 lose precision).
    U32,
    /// Signed 32-bit integer (decoded to `f32`, so magnitudes above 2^24 lose precision).
    I32,
    /// 32-bit IEEE float.
    F32,
    /// 64-bit IEEE float (decoded to `f32`; values beyond the `f32` range become infinite and are rejected).
    F64,
}

impl VoxelType {
    /// Size of one voxel in bytes.
    pub fn bytes(self) -> usize {
        match self {
            VoxelType::U8 | VoxelType::I8 => 1,
            VoxelType::U16 | VoxelType::I16 => 2,
            VoxelType::U32 | VoxelType::I32 | VoxelType::F32 => 4,
            VoxelType::F64 => 8,
        }
    }

    /// Canonical short name ("u8", "i16", "f32", ...).
    pub fn name(self) -> &'static str {
        match self {
            VoxelType::U8 => "u8",
            VoxelType::I8 => "i8",
            VoxelType::U16 => "u16",
            VoxelType::I16 => "i16",
            VoxelType::U32 => "u32",
            VoxelType::I32 => "i32",
            VoxelType::F32 => "f32",
            VoxelType::F64 => "f64",
        }
    }

    /// Parses the usual C / NRRD / Rust spellings ("u8", "uint8", "uchar", "unsigned short", "float", ...), case-insensitively.
    pub fn from_name(name: &str) -> Option<Self> {
        // Collapse inner whitespace so "unsigned  short" and "unsigned short" match alike.
        let norm = name.split_whitespace().collect::<Vec<_>>().join(" ").to_ascii_lowercase();
        let ty = match norm.as_str() {
            "u8" | "uint8" | "uint8_t" | "uchar" | "unsigned char" | "byte" | "ubyte" => VoxelType::U8,
            "i8" | "int8" | "int8_t" | "char" | "schar" | "signed char" => VoxelType::I8,
            "u16" | "uint16" | "uint16_t" | "ushort" | "unsigned short" | "unsigned short int" => VoxelType::U16,
            "i16" | "int16" | "int16_t" | "short" | "short int" | "signed short" | "signed short int" => VoxelType::I16,
            "u32" | "uint32" | "uint32_t" | "uint" | "unsigned int" | "unsigned" => VoxelType::U32,
            "i32" | "int32" | "int32_t" | "int" | "signed int" | "signed" => VoxelType::I32,
            "f32" | "float" | "float32" | "single" => VoxelType::F32,
            "f64" | "double" | "float64" => VoxelType::F64,
            _ => return None,
        };
        Some(ty)
    }
}

impl fmt::Display for VoxelType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for VoxelType {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        VoxelType::from_name(s)
            .ok_or_else(|| format!("unknown voxel type \"{s}\"; expected one of u8, i8, u16, i16, u32, i32, f32, f64"))
    }
}

/// Byte order of multi-byte voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Endian {
    /// Least significant byte first (x86, most files).
    #[default]
    Little,
    /// Most significant byte first.
    Big,
}

impl Endian {
    /// Parses "little"/"le"/"big"/"be", case-insensitively.
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "little" | "le" | "little-endian" | "little_endian" => Some(Endian::Little),
            "big" | "be" | "big-endian" | "big_endian" => Some(Endian::Big),
            _ => None,
        }
    }
}

impl fmt::Display for Endian {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Endian::Little => "little",
            Endian::Big => "big",
        })
    }
}

impl FromStr for Endian {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Endian::from_name(s).ok_or_else(|| format!("unknown endianness \"{s}\"; expected little or big"))
    }
}

/// Decodes `bytes` (whose length must be a multiple of `ty.bytes()`; any remainder is ignored) to `f32`.
pub(crate) fn decode(bytes: &[u8], ty: VoxelType, endian: Endian) -> Vec<f32> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            bytes
                .chunks_exact($n)
                .map(|c| {
                    let mut a = [0u8; $n];
                    a.copy_from_slice(c);
                    (match endian {
                        Endian::Little => <$t>::from_le_bytes(a),
                        Endian::Big => <$t>::from_be_bytes(a),
                    }) as f32
                })
                .collect()
        };
    }
    match ty {
        VoxelType::U8 => bytes.iter().map(|&b| f32::from(b)).collect(),
        VoxelType::I8 => bytes.iter().map(|&b| f32::from(b as i8)).collect(),
        VoxelType::U16 => conv!(u16, 2),
        VoxelType::I16 => conv!(i16, 2),
        VoxelType::U32 => conv!(u32, 4),
        VoxelType::I32 => conv!(i32, 4),
        VoxelType::F32 => conv!(f32, 4),
        VoxelType::F64 => conv!(f64, 8),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_both_byte_orders() {
        assert_eq!(decode(&[1, 2], VoxelType::U16, Endian::Little), vec![513.0]);
        assert_eq!(decode(&[1, 2], VoxelType::U16, Endian::Big), vec![258.0]);
        assert_eq!(decode(&[0xff, 0xfe], VoxelType::I16, Endian::Big), vec![-2.0]);
        assert_eq!(decode(&[0x80], VoxelType::I8, Endian::Little), vec![-128.0]);
        assert_eq!(decode(&1.5f64.to_be_bytes(), VoxelType::F64, Endian::Big), vec![1.5]);
    }

    #[test]
    fn parses_type_names() {
        for (n, t) in [
            ("uchar", VoxelType::U8),
            ("Unsigned  Char", VoxelType::U8),
            ("ushort", VoxelType::U16),
            ("short", VoxelType::I16),
            ("float", VoxelType::F32),
            ("double", VoxelType::F64),
            ("uint32_t", VoxelType::U32),
        ] {
            assert_eq!(VoxelType::from_name(n), Some(t), "{n}");
        }
        assert_eq!(VoxelType::from_name("int64"), None);
        assert!("bogus".parse::<VoxelType>().is_err());
    }
}
