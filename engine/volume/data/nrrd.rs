//! NRRD (`.nrrd` with attached data after the first blank line, `.nhdr` with detached data).

use std::fs::File;
use std::io::Read;
use std::path::Path;

use super::metaimage::read_header_lines;
use super::read::{DataRegion, Start};
use super::{
    finish_region, ignored_option_warnings, Endian, Layout, LoadOptions, Progress, Volume, VolumeError, VoxelType,
};

/// A header field value with its 1-based line number.
type Field = Option<(usize, String)>;

#[derive(Default)]
struct Fields {
    dimension: Field,
    ty: Field,
    sizes: Field,
    endian: Field,
    encoding: Field,
    spacings: Field,
    space_directions: Field,
    byte_skip: Field,
    line_skip: Field,
    data_file: Field,
}

/// Splits `space directions` into per-axis tokens: "none" or a parenthesized vector (which may contain spaces).
fn direction_tokens(value: &str) -> Option<Vec<&str>> {
    let mut out = Vec::new();
    let mut rest = value.trim_start();
    while !rest.is_empty() {
        let end = if rest.starts_with('(') {
            rest.find(')')? + 1
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        out.push(&rest[..end]);
        rest = rest[end..].trim_start();
    }
    Some(out)
}

fn parse_vector(token: &str) -> Option<f64> {
    let inner = token.strip_prefix('(')?.strip_suffix(')')?;
    let comps: Vec<f64> = inner.split(',').map(|c| c.trim().parse::<f64>().ok()).collect::<Option<_>>()?;
    if comps.is_empty() {
        return None;
    }
    Some(comps.iter().map(|c| c * c).sum::<f64>().sqrt())
}

pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let herr = |line: usize, message: String| VolumeError::Header { file: file.clone(), line, message };

    let mut magic = [0u8; 8];
    let got = File::open(path)
        .and_then(|f| f.take(8).read(&mut magic))
        .map_err(|source| VolumeError::Io { file: file.clone(), source })?;
    if got < 8 || !magic.starts_with(b"NRRD000") || !magic[7].is_ascii_digit() {
        return Err(herr(1, "not a NRRD file: the first line must start with the magic NRRD000<version>".into()));
    }

    let (lines, _) = read_header_lines(path, |l| l.trim().is_empty())?;
    let header_end = lines.last().map_or(0, |l| l.end);
    let last_line = lines.last().map_or(1, |l| l.number);
    let mut f = Fields::default();
    for l in lines.iter().skip(1) {
        let text = l.text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let Some((key, value)) = text.split_once(':') else {
            return Err(herr(l.number, format!("expected \"field: value\", found \"{text}\"")));
        };
        if value.starts_with('=') {
            // key:=value pairs are free-form metadata.
            continue;
        }
        let entry = Some((l.number, value.trim().to_owned()));
        match key.trim().to_ascii_lowercase().as_str() {
            "dimension" => f.dimension = entry,
            "type" => f.ty = entry,
            "sizes" => f.sizes = entry,
            "endian" => f.endian = entry,
            "encoding" => f.encoding = entry,
            "spacings" => f.spacings = entry,
            "space directions" => f.space_directions = entry,
            "byte skip" | "byteskip" => f.byte_skip = entry,
            "line skip" | "lineskip" => f.line_skip = entry,
            "data file" | "datafile" => f.data_file = entry,
            // Orientation, labels, kinds, units, centerings etc. do not affect the voxel values.
            _ => {}
        }
    }
    let required = |field: &Field, name: &str| -> Result<(usize, String), VolumeError> {
        field.clone().ok_or_else(|| herr(last_line, format!("header has no \"{name}\" field")))
    };

    let (line, v) = required(&f.dimension, "dimension")?;
    let dimension: usize = v.parse().map_err(|_| herr(line, format!("dimension \"{v}\" is not a number")))?;
    if !(2..=4).contains(&dimension) {
        return Err(herr(
            line,
            format!("dimension {dimension} is not supported (3; 4 with a first axis of size 1; or 2)"),
        ));
    }

    let (line, v) = required(&f.sizes, "sizes")?;
    let sizes: Vec<u64> = v
        .split_whitespace()
        .map(|t| t.parse::<u64>().map_err(|_| herr(line, format!("sizes value \"{t}\" is not a valid size"))))
        .collect::<Result<_, _>>()?;
    if sizes.len() != dimension {
        return Err(herr(line, format!("sizes has {} values but dimension is {dimension}", sizes.len())));
    }
    // A 4-D file is accepted only when its first (fastest) axis is a single channel.
    let first_axis = usize::from(dimension == 4);
    if dimension == 4 && sizes[0] != 1 {
        return Err(herr(
            line,
            format!("4-D data with {} values per voxel: only single-channel volumes are supported", sizes[0]),
        ));
    }
    let spatial = &sizes[first_axis..];
    let dims = [spatial[0], spatial[1], spatial.get(2).copied().unwrap_or(1)];

    let (line, v) = required(&f.ty, "type")?;
    let voxel = VoxelType::from_name(&v).ok_or_else(|| VolumeError::UnsupportedType {
        file: file.clone(),
        type_name: v.clone(),
        location: format!("line {line}"),
    })?;

    let (eline, encoding) = required(&f.encoding, "encoding")?;
    let compressed = match encoding.to_ascii_lowercase().as_str() {
        "raw" => false,
        "gzip" | "gz" => true,
        "ascii" | "text" | "txt" | "hex" | "bzip2" | "bz2" => {
            return Err(herr(
                eline,
                format!("encoding \"{encoding}\" is not supported; re-save the volume with raw or gzip encoding"),
            ))
        }
        _ => return Err(herr(eline, format!("unknown encoding \"{encoding}\" (supported: raw, gzip)"))),
    };

    let endian = match &f.endian {
        Some((line, v)) => {
            Endian::from_name(v).ok_or_else(|| herr(*line, format!("endian \"{v}\" is not little or big")))?
        }
        None if voxel.bytes() > 1 => {
            return Err(herr(last_line, format!("header has no \"endian\" field, required for {voxel} data")));
        }
        None => Endian::Little,
    };

    let mut spacing = [1.0f64; 3];
    if let Some((line, v)) = &f.space_directions {
        let toks = direction_tokens(v).ok_or_else(|| herr(*line, "space directions has an unclosed \"(\"".into()))?;
        if toks.len() != dimension {
            return Err(herr(
                *line,
                format!("space directions has {} entries but dimension is {dimension}", toks.len()),
            ));
        }
        for (i, t) in toks[first_axis..].iter().enumerate() {
            spacing[i] = parse_vector(t)
                .ok_or_else(|| herr(*line, format!("space direction \"{t}\" is not a vector like (1,0,0)")))?;
        }
    } else if let Some((line, v)) = &f.spacings {
        let vals: Vec<f64> = v
            .split_whitespace()
            .map(|t| t.parse::<f64>().map_err(|_| herr(*line, format!("spacings value \"{t}\" is not a number"))))
            .collect::<Result<_, _>>()?;
        if vals.len() != dimension {
            return Err(herr(*line, format!("spacings has {} values but dimension is {dimension}", vals.len())));
        }
        // NRRD allows negative spacing to encode axis direction; the magnitude is the voxel size.
        for (i, s) in vals[first_axis..].iter().enumerate() {
            spacing[i] = s.abs();
        }
    }
    let spacing = opts.spacing.map(|s| s.map(f64::from)).unwrap_or(spacing);

    let start = match &f.byte_skip {
        None => Start::Skip(0),
        Some((line, v)) => match v.parse::<i64>() {
            Ok(-1) if !compressed => Start::FromEnd,
            Ok(n) if n >= 0 => Start::Skip(n as u64),
            _ => return Err(herr(*line, format!("byte skip \"{v}\" must be >= 0 (or -1 for raw encoding)"))),
        },
    };
    let line_skip = match &f.line_skip {
        None => 0,
        Some((line, v)) => v.parse::<u64>().map_err(|_| herr(*line, format!("line skip \"{v}\" must be >= 0")))?,
    };

    let (data_path, offset) = match &f.data_file {
        Some((line, v)) => {
            if v.eq_ignore_ascii_case("list") || v.split_whitespace().count() > 1 {
                return Err(herr(
                    *line,
                    format!("data file \"{v}\": multi-file data (LIST or file patterns) is not supported"),
                ));
            }
            (path.parent().unwrap_or(Path::new("")).join(v), 0)
        }
        None if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("nhdr")) => {
            return Err(herr(last_line, "detached header (.nhdr) has no \"data file\" field".into()));
        }
        None => (path.to_path_buf(), header_end),
    };

    let layout = Layout::validated(&file, dims, voxel, endian, spacing, opts)?;
    let region = DataRegion {
        path: &data_path,
        offset,
        line_skip,
        start,
        compressed,
        compressed_size: None,
        expected: layout.byte_len(),
    };
    finish_region(&file, &layout, &region, opts, ignored_option_warnings(opts, &layout), progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn space_direction_tokens_allow_spaces_inside_vectors() {
        let t = direction_tokens("none (1, 0, 0) (0,2,0)  (0,0,3.5)");
        assert_eq!(t, Some(vec!["none", "(1, 0, 0)", "(0,2,0)", "(0,0,3.5)"]));
        assert_eq!(parse_vector("(0,0,3.5)"), Some(3.5));
        assert_eq!(parse_vector("(3,4,0)"), Some(5.0));
        assert_eq!(direction_tokens("(1,0,0"), None);
    }
}
