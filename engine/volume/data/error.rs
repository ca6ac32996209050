//! Errors from loading or constructing a volume; every message starts with the file (or source).

/// Why a volume could not be loaded or built. `Display` always starts with the file path.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// The file (or a sidecar / detached data file) could not be read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// The file that failed.
        file: String,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// The file holds fewer voxel bytes than dims × voxel type require.
    #[error("{file}: truncated voxel data: expected {expected} bytes, got {got}")]
    Truncated {
        /// The data file.
        file: String,
        /// Bytes required by dims × voxel type.
        expected: u64,
        /// Bytes available.
        got: u64,
    },
    /// The file holds more voxel bytes than dims × voxel type require.
    #[error("{file}: size mismatch: file has {got} bytes of voxel data but dims × type need {expected}{hint}")]
    SizeMismatch {
        /// The data file.
        file: String,
        /// Bytes required by dims × voxel type.
        expected: u64,
        /// Bytes available.
        got: u64,
        /// Suggested dims / type that would fit (empty, or starting with "; ").
        hint: String,
    },
    /// A dimension is zero.
    #[error("{file}: zero dimension in dims {}x{}x{}: every axis needs at least one voxel", dims[0], dims[1], dims[2])]
    ZeroDimension {
        /// The file or source.
        file: String,
        /// The offending dims.
        dims: [u64; 3],
    },
    /// A raw file has no dims / voxel type in the options and no usable sidecar.
    #[error(
        "{file}: raw volume is missing {missing}; pass them as options (--dims X,Y,Z --type u8|u16|i16|f32|...) \
         or write a sidecar {file}.json like {{\"dims\":[256,256,128],\"type\":\"u16\",\"endian\":\"little\",\"spacing\":[1,1,1]}}"
    )]
    MissingRawParameters {
        /// The raw file.
        file: String,
        /// What is missing, e.g. "dims and voxel type".
        missing: String,
    },
    /// A header (or sidecar) field is unparseable, missing or unsupported.
    #[error("{file}:{line}: header error: {message}")]
    Header {
        /// The header or sidecar file.
        file: String,
        /// 1-based line of the offending field (the header's last line when a field is missing).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The voxel type is not one this loader can decode.
    #[error(
        "{file}: unsupported voxel type \"{type_name}\" ({location}); supported: u8, i8, u16, i16, u32, i32, f32, f64"
    )]
    UnsupportedType {
        /// The header, sidecar or data file.
        file: String,
        /// The type as written.
        type_name: String,
        /// Where it was found, e.g. "line 4" or "sidecar field \"type\"".
        location: String,
    },
    /// Compressed voxel data could not be decompressed.
    #[error("{file}: cannot decompress voxel data: {message}")]
    Decompress {
        /// The data file.
        file: String,
        /// The decoder's complaint.
        message: String,
    },
    /// The data contains infinite values (or only NaN), which have no meaningful value range.
    #[error(
        "{file}: {count} non-finite voxel(s) ({value}), first at ({}, {}, {}); fix the data or convert it to finite values",
        first[0], first[1], first[2]
    )]
    NonFinite {
        /// The file or source.
        file: String,
        /// Number of non-finite voxels.
        count: u64,
        /// The first non-finite value found.
        value: f32,
        /// Coordinate (x, y, z) of the first one.
        first: [u32; 3],
    },
    /// The data contains negative values and `allow_negative` is off.
    #[error(
        "{file}: {count} negative voxel(s), minimum {min}, first at ({}, {}, {}); set LoadOptions::allow_negative \
         (--allow-negative) to map them through the value range",
        first[0], first[1], first[2]
    )]
    Negative {
        /// The file or source.
        file: String,
        /// Number of negative voxels.
        count: u64,
        /// The most negative value.
        min: f32,
        /// Coordinate (x, y, z) of the first negative voxel.
        first: [u32; 3],
    },
    /// A dimension exceeds the device / caller limit.
    #[error("{file}: dims {}x{}x{} exceed the largest accepted size, {limit} voxels per axis (a device's is 64 x its maxImageDimension3D: the sparse layout's page directory)", dims[0], dims[1], dims[2])]
    TooLarge {
        /// The file or source.
        file: String,
        /// The offending dims.
        dims: [u64; 3],
        /// The per-axis limit (`LoadOptions::max_dimension`).
        limit: u32,
    },
    /// The total voxel count overflows or exceeds what the loader accepts.
    #[error("{file}: dims {}x{}x{} give too many voxels (limit {limit})", dims[0], dims[1], dims[2])]
    TooManyVoxels {
        /// The file or source.
        file: String,
        /// The offending dims.
        dims: [u64; 3],
        /// Maximum voxel count.
        limit: u64,
    },
    /// Voxel spacing is non-finite, zero or negative.
    #[error("{file}: bad spacing {}, {}, {}: each axis must be finite and > 0", spacing[0], spacing[1], spacing[2])]
    BadSpacing {
        /// The file or source.
        file: String,
        /// The offending spacing.
        spacing: [f64; 3],
    },
    /// `Volume::new` got a data vector whose length does not match dims.
    #[error("{file}: data has {got} values but dims need {expected}")]
    DataLength {
        /// The source.
        file: String,
        /// dims product.
        expected: u64,
        /// Actual length.
        got: u64,
    },
    /// A procedural generator parameter is out of range.
    #[error("{file}: bad parameter: {message}")]
    BadParameter {
        /// The procedural source description.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A self-describing file (DICOM, NIfTI, OpenVDB) is malformed, inconsistent or uses a feature the loader lacks.
    #[error("{file}: {message}")]
    Invalid {
        /// The file (or folder) at fault.
        file: String,
        /// What is wrong, phrased for the user.
        message: String,
    },
    /// The volume's GPU images cannot fit the device, so it is refused before anything is allocated.
    #[error(
        "{file}: dims {}x{}x{} need {needed} bytes of GPU memory but {what} holds {available} bytes; crop or downsample the volume",
        dims[0], dims[1], dims[2]
    )]
    DeviceMemory {
        /// The file or source.
        file: String,
        /// The volume's dims.
        dims: [u64; 3],
        /// Bytes the volume needs.
        needed: u64,
        /// Bytes the device offers.
        available: u64,
        /// Which limit it exceeds.
        what: &'static str,
    },
}
