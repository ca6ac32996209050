//! MetaImage (`.mhd` header + data file, or `.mha` with the data after the header).

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::read::{DataRegion, Start};
use super::{
    finish_region, ignored_option_warnings, Endian, Layout, LoadOptions, Progress, Volume, VolumeError, VoxelType,
};

/// Longest header line accepted; anything longer is binary data in a file that is not a MetaImage header.
pub(crate) const MAX_LINE: u64 = 64 * 1024;

/// One text header line (1-based number) and its byte offset just past the line.
pub(crate) struct HeaderLine {
    pub number: usize,
    pub text: String,
    pub end: u64,
}

/// Reads header lines until `stop` returns true for a line or the file ends.
pub(crate) fn read_header_lines(
    path: &Path,
    mut stop: impl FnMut(&str) -> bool,
) -> Result<(Vec<HeaderLine>, bool), VolumeError> {
    let file = path.display().to_string();
    let f = File::open(path).map_err(|source| VolumeError::Io { file: file.clone(), source })?;
    let mut reader = BufReader::new(f);
    let mut lines = Vec::new();
    let mut offset = 0u64;
    loop {
        let mut buf = Vec::new();
        let n = (&mut reader)
            .take(MAX_LINE)
            .read_until(b'\n', &mut buf)
            .map_err(|source| VolumeError::Io { file: file.clone(), source })?;
        if n == 0 {
            return Ok((lines, false));
        }
        let number = lines.len() + 1;
        if n as u64 == MAX_LINE && buf.last() != Some(&b'\n') {
            return Err(VolumeError::Header {
                file,
                line: number,
                message: format!("line longer than {MAX_LINE} bytes: this does not look like a text header"),
            });
        }
        offset += n as u64;
        let text = String::from_utf8(buf).map_err(|_| VolumeError::Header {
            file: file.clone(),
            line: number,
            message: "header line is not valid UTF-8 text (binary data before the end of the header?)".into(),
        })?;
        let text = text.trim_end_matches(['\n', '\r']).to_owned();
        let done = stop(&text);
        lines.push(HeaderLine { number, text, end: offset });
        if done {
            return Ok((lines, true));
        }
    }
}

struct Fields {
    file: String,
    map: HashMap<String, (usize, String)>,
    last_line: usize,
}

impl Fields {
    fn get(&self, key: &str) -> Option<(usize, &str)> {
        self.map.get(&key.to_ascii_lowercase()).map(|(l, v)| (*l, v.as_str()))
    }

    fn err(&self, line: usize, message: String) -> VolumeError {
        VolumeError::Header { file: self.file.clone(), line, message }
    }

    fn required(&self, key: &str) -> Result<(usize, &str), VolumeError> {
        self.get(key).ok_or_else(|| self.err(self.last_line, format!("header has no {key} field")))
    }

    fn numbers<T: std::str::FromStr>(&self, key: &str, line: usize, value: &str) -> Result<Vec<T>, VolumeError> {
        value
            .split_whitespace()
            .map(|t| t.parse::<T>().map_err(|_| self.err(line, format!("{key} value \"{t}\" is not a valid number"))))
            .collect()
    }

    fn boolean(&self, key: &str) -> Result<bool, VolumeError> {
        match self.get(key) {
            None => Ok(false),
            Some((line, v)) => match v.to_ascii_lowercase().as_str() {
                "true" | "1" | "yes" => Ok(true),
                "false" | "0" | "no" => Ok(false),
                _ => Err(self.err(line, format!("{key} = \"{v}\" is not True or False"))),
            },
        }
    }
}

fn element_type(name: &str) -> Option<VoxelType> {
    Some(match name.to_ascii_uppercase().as_str() {
        "MET_UCHAR" => VoxelType::U8,
        "MET_CHAR" => VoxelType::I8,
        "MET_USHORT" => VoxelType::U16,
        "MET_SHORT" => VoxelType::I16,
        "MET_UINT" => VoxelType::U32,
        "MET_INT" => VoxelType::I32,
        "MET_FLOAT" => VoxelType::F32,
        "MET_DOUBLE" => VoxelType::F64,
        _ => return None,
    })
}

pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let (lines, _) = read_header_lines(path, |l| {
        l.split_once('=').is_some_and(|(k, _)| k.trim().eq_ignore_ascii_case("ElementDataFile"))
    })?;
    let mut map = HashMap::new();
    for l in &lines {
        if l.text.trim().is_empty() {
            continue;
        }
        let Some((k, v)) = l.text.split_once('=') else {
            return Err(VolumeError::Header {
                file,
                line: l.number,
                message: format!("expected \"Key = Value\", found \"{}\"", l.text.trim()),
            });
        };
        map.insert(k.trim().to_ascii_lowercase(), (l.number, v.trim().to_owned()));
    }
    let header_end = lines.last().map_or(0, |l| l.end);
    let f = Fields { file: file.clone(), map, last_line: lines.last().map_or(1, |l| l.number) };

    let (line, v) = f.required("NDims")?;
    let ndims: usize = v.parse().map_err(|_| f.err(line, format!("NDims = \"{v}\" is not a number")))?;
    if !(ndims == 2 || ndims == 3) {
        return Err(f.err(line, format!("NDims = {ndims} is not supported (only 3, or 2 as a single slice)")));
    }
    let (line, v) = f.required("DimSize")?;
    let sizes: Vec<u64> = f.numbers("DimSize", line, v)?;
    if sizes.len() != ndims {
        return Err(f.err(line, format!("DimSize has {} values but NDims = {ndims}", sizes.len())));
    }
    let dims = [sizes[0], sizes[1], sizes.get(2).copied().unwrap_or(1)];

    let (line, v) = f.required("ElementType")?;
    let voxel = element_type(v).ok_or_else(|| VolumeError::UnsupportedType {
        file: file.clone(),
        type_name: v.to_owned(),
        location: format!(
            "line {line}; MetaImage types: MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, MET_FLOAT, MET_DOUBLE"
        ),
    })?;
    if let Some((line, v)) = f.get("ElementNumberOfChannels") {
        if v != "1" {
            return Err(f.err(
                line,
                format!("ElementNumberOfChannels = {v}: only single-channel (scalar) volumes are supported"),
            ));
        }
    }

    let spacing = match f.get("ElementSpacing").or_else(|| f.get("ElementSize")) {
        Some((line, v)) => {
            let s: Vec<f64> = f.numbers("ElementSpacing", line, v)?;
            if s.len() != ndims {
                return Err(f.err(line, format!("ElementSpacing has {} values but NDims = {ndims}", s.len())));
            }
            [s[0], s[1], s.get(2).copied().unwrap_or(1.0)]
        }
        None => [1.0; 3],
    };
    let spacing = opts.spacing.map(|s| s.map(f64::from)).unwrap_or(spacing);

    let msb = f.boolean("BinaryDataByteOrderMSB")? || f.boolean("ElementByteOrderMSB")?;
    let endian = if msb { Endian::Big } else { Endian::Little };
    let compressed = f.boolean("CompressedData")?;
    let compressed_size = match f.get("CompressedDataSize") {
        Some((line, v)) => Some(
            v.parse::<u64>().map_err(|_| f.err(line, format!("CompressedDataSize = \"{v}\" is not a byte count")))?,
        ),
        None => None,
    };
    let start = match f.get("HeaderSize") {
        None => Start::Skip(0),
        Some((line, v)) => match v.parse::<i64>() {
            Ok(-1) if !compressed => Start::FromEnd,
            Ok(n) if n >= 0 => Start::Skip(n as u64),
            _ => {
                return Err(f.err(
                    line,
                    format!("HeaderSize = \"{v}\" must be a byte count >= 0 (or -1 for uncompressed data)"),
                ))
            }
        },
    };

    let (data_line, data_file) = f.required("ElementDataFile")?;
    let lower = data_file.to_ascii_lowercase();
    if lower == "list" || data_file.contains('%') || data_file.split_whitespace().count() > 1 {
        return Err(f.err(
            data_line,
            format!("ElementDataFile = {data_file}: multi-file data (LIST or file patterns) is not supported"),
        ));
    }
    let (data_path, offset) = if lower == "local" {
        (path.to_path_buf(), header_end)
    } else {
        (path.parent().unwrap_or(Path::new("")).join(data_file), 0)
    };

    let layout = Layout::validated(&file, dims, voxel, endian, spacing, opts)?;
    let region = DataRegion {
        path: &data_path,
        offset,
        line_skip: 0,
        start,
        compressed,
        compressed_size,
        expected: layout.byte_len(),
    };
    finish_region(&file, &layout, &region, opts, ignored_option_warnings(opts, &layout), progress)
}
