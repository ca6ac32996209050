//! Checks a DICOM file before `dicom-object` parses it and before `dicom-pixeldata` decodes it,
//! for two weaknesses the fuzzer found in those crates:
//!
//! - the parser reserves and zero-fills an element's declared length before reading it, so a
//!   1 KB file whose length field says 4 GB costs 4 GB of memory: [`check_lengths`] walks the
//!   element headers (without reading values) and refuses a length longer than what remains;
//! - the RLE Lossless decoder indexes past short fragments and segments (a panic):
//!   [`check_rle`] validates each fragment's header and decodes each segment's PackBits length.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

/// Implicit VR Little Endian.
const IMPLICIT_LE: &str = "1.2.840.10008.1.2";
/// Explicit VR Big Endian (retired, still readable).
const EXPLICIT_BE: &str = "1.2.840.10008.1.2.2";
/// Deflated Explicit VR Little Endian: the data set is compressed, so its lengths are not checked here.
const DEFLATED: &str = "1.2.840.10008.1.2.1.99";
/// RLE Lossless.
pub(crate) const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// Explicit VRs with a 2-byte length; every other VR (unknown ones included, which the parser
/// reads as UN) has a 2-byte reserved field and a 4-byte length.
const SHORT_VRS: [&[u8; 2]; 21] = [
    b"AE", b"AS", b"AT", b"CS", b"DA", b"DS", b"DT", b"FL", b"FD", b"IS", b"LO", b"LT", b"PN", b"SH", b"SL", b"SS",
    b"ST", b"TM", b"UI", b"UL", b"US",
];

/// Element headers read from a file, with the bytes left after the current position.
struct Cursor {
    r: BufReader<File>,
    pos: u64,
    len: u64,
}

impl Cursor {
    fn bytes<const N: usize>(&mut self) -> Option<[u8; N]> {
        let mut b = [0u8; N];
        self.r.read_exact(&mut b).ok()?;
        self.pos += N as u64;
        Some(b)
    }

    fn skip(&mut self, n: u64) -> Option<()> {
        self.r.seek_relative(i64::try_from(n).ok()?).ok()?;
        self.pos += n;
        Some(())
    }

    fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }
}

/// Refuses an element whose declared length exceeds the bytes left in the file. Stops quietly
/// (leaving the verdict to the parser) wherever the stream is not what it expects.
pub(crate) fn check_lengths(path: &Path) -> Result<(), String> {
    let Ok(f) = File::open(path) else { return Ok(()) };
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    let mut c = Cursor { r: BufReader::new(f), pos: 0, len };
    // Part 10: 128-byte preamble and "DICM", then the explicit-VR little-endian meta group.
    let Some(pre) = c.bytes::<132>() else { return Ok(()) };
    if &pre[128..] != b"DICM" {
        return Ok(());
    }
    let mut syntax = String::new();
    // The meta group: read its elements (lengths checked) until the group changes.
    loop {
        let here = c.pos;
        let Some(group) = c.bytes::<2>().map(u16::from_le_bytes) else { return Ok(()) };
        if group != 0x0002 {
            // Rewind the two bytes: the data set starts here.
            if c.r.seek_relative(-2).is_err() {
                return Ok(());
            }
            c.pos = here;
            break;
        }
        let Some(elem) = c.bytes::<2>().map(u16::from_le_bytes) else { return Ok(()) };
        let n = match header_len(&mut c, true, false) {
            None => return Ok(()),
            Some(Err(vr)) => return Err(bad_vr(0x0002, elem, vr)),
            Some(Ok((None, _))) => return Err(format!("meta element (0002,{elem:04X}) has an undefined length")),
            Some(Ok((Some(n), _))) => n,
        };
        if n > c.remaining() {
            return Err(too_long(0x0002, elem, n, c.remaining()));
        }
        if elem == 0x0010 && n <= 64 {
            let mut v = vec![0u8; n as usize];
            if c.r.read_exact(&mut v).is_err() {
                return Ok(());
            }
            c.pos += n;
            syntax = String::from_utf8_lossy(&v).trim_end_matches(['\0', ' ']).to_string();
        } else if c.skip(n).is_none() {
            return Ok(());
        }
    }
    if syntax == DEFLATED {
        return Ok(());
    }
    let explicit = syntax != IMPLICIT_LE;
    let big = syntax == EXPLICIT_BE;
    // The data set: skip defined-length values, step into sequences and items (their contents
    // are elements too), skip encapsulated pixel-data fragments.
    let mut fragments = false;
    while c.remaining() >= 8 {
        let Some(t) = c.bytes::<4>() else { return Ok(()) };
        let (group, elem) = if big {
            (u16::from_be_bytes([t[0], t[1]]), u16::from_be_bytes([t[2], t[3]]))
        } else {
            (u16::from_le_bytes([t[0], t[1]]), u16::from_le_bytes([t[2], t[3]]))
        };
        if group == 0xFFFE {
            // Item and delimiters: no VR, a 4-byte length.
            let Some(l) = c.bytes::<4>() else { return Ok(()) };
            let n = u64::from(if big { u32::from_be_bytes(l) } else { u32::from_le_bytes(l) });
            match elem {
                0xE0DD => fragments = false,
                0xE000 if n != 0xFFFF_FFFF => {
                    if n > c.remaining() {
                        return Err(too_long(group, elem, n, c.remaining()));
                    }
                    if fragments && c.skip(n).is_none() {
                        return Ok(());
                    }
                }
                _ => {}
            }
            continue;
        }
        let (n, sq) = match header_len(&mut c, explicit, big) {
            None => return Ok(()),
            Some(Err(vr)) => return Err(bad_vr(group, elem, vr)),
            Some(Ok(h)) => h,
        };
        match n {
            // Encapsulated pixel data: its items are fragments.
            None if (group, elem) == (0x7FE0, 0x0010) => fragments = true,
            // An undefined-length sequence: its items follow.
            None if sq != Some(false) => {}
            // An undefined-length UN holds implicit-VR data this walk does not follow.
            None => return Ok(()),
            Some(n) => {
                if n > c.remaining() {
                    return Err(too_long(group, elem, n, c.remaining()));
                }
                // A defined-length sequence's items follow; anything else is skipped.
                let into = sq.unwrap_or_else(|| starts_item(&mut c, big));
                if !into && c.skip(n).is_none() {
                    return Ok(());
                }
            }
        }
    }
    Ok(())
}

/// Whether the next bytes are an item tag (FFFE,E000), without consuming them.
fn starts_item(c: &mut Cursor, big: bool) -> bool {
    let Some(t) = c.bytes::<4>() else { return false };
    if c.r.seek_relative(-4).is_err() {
        return false;
    }
    c.pos -= 4;
    let item = if big { [0xFF, 0xFE, 0xE0, 0x00] } else { [0xFE, 0xFF, 0x00, 0xE0] };
    t == item
}

/// What follows a tag: the length (`None` when undefined) and whether the element is a sequence
/// (`None` when the VR is implicit, so unknown).
type Header = (Option<u64>, Option<bool>);

/// Reads the VR (explicit) and length after a tag; `Err` holds a VR that is not two capital
/// letters (the parser would read such an element as UN with whatever length follows).
fn header_len(c: &mut Cursor, explicit: bool, big: bool) -> Option<Result<Header, [u8; 2]>> {
    let u32_of = |b: [u8; 4]| if big { u32::from_be_bytes(b) } else { u32::from_le_bytes(b) };
    let (n, sq) = if explicit {
        let vr = c.bytes::<2>()?;
        if !vr.iter().all(u8::is_ascii_uppercase) {
            return Some(Err(vr));
        }
        let n = if SHORT_VRS.contains(&&vr) {
            let b = c.bytes::<2>()?;
            u32::from(if big { u16::from_be_bytes(b) } else { u16::from_le_bytes(b) })
        } else {
            c.bytes::<2>()?;
            u32_of(c.bytes::<4>()?)
        };
        (n, Some(&vr == b"SQ"))
    } else {
        (u32_of(c.bytes::<4>()?), None)
    };
    Some(Ok(((n != 0xFFFF_FFFF).then_some(u64::from(n)), sq)))
}

fn bad_vr(group: u16, elem: u16, vr: [u8; 2]) -> String {
    format!(
        "element ({group:04X},{elem:04X}) has no valid value representation ({:?}): corrupt file",
        String::from_utf8_lossy(&vr)
    )
}

fn too_long(group: u16, elem: u16, n: u64, left: u64) -> String {
    format!(
        "element ({group:04X},{elem:04X}) claims {n} bytes but only {left} remain in the file (corrupt or truncated)"
    )
}

/// Validates RLE Lossless fragments (one per frame) for `segments` segments of `plane` bytes
/// each, as PS3.5 Annex G lays them out: a 64-byte header with the segment count (≤ 15) and
/// increasing offsets inside the fragment, and PackBits runs that decode to at least `plane` bytes.
pub(crate) fn check_rle(fragments: &[Vec<u8>], frames: u32, segments: usize, plane: usize) -> Result<(), String> {
    if fragments.len() != frames as usize {
        return Err(format!(
            "RLE: {} fragment(s) for {frames} frame(s); each frame must be one fragment",
            fragments.len()
        ));
    }
    for (i, frag) in fragments.iter().enumerate() {
        if frag.len() < 64 {
            return Err(format!("RLE frame {i}: fragment of {} bytes is shorter than its 64-byte header", frag.len()));
        }
        let word = |k: usize| u32::from_le_bytes([frag[4 * k], frag[4 * k + 1], frag[4 * k + 2], frag[4 * k + 3]]);
        let count = word(0) as usize;
        if count != segments {
            return Err(format!("RLE frame {i}: {count} segment(s), the image needs {segments}"));
        }
        let mut offsets: Vec<usize> = (1..=count).map(|k| word(k) as usize).collect();
        offsets.push(frag.len());
        for s in 0..count {
            let (a, b) = (offsets[s], offsets[s + 1]);
            if a < 64 || a > b || b > frag.len() {
                return Err(format!("RLE frame {i}: segment {s} offsets {a}..{b} lie outside the fragment"));
            }
            let decoded = packbits_len(&frag[a..b], plane);
            if decoded < plane {
                return Err(format!("RLE frame {i}: segment {s} decodes to {decoded} bytes, the image needs {plane}"));
            }
        }
    }
    Ok(())
}

/// Bytes the PackBits runs in `seg` decode to (complete runs only), stopping once `need` is reached.
fn packbits_len(seg: &[u8], need: usize) -> usize {
    let (mut i, mut out) = (0, 0);
    while i < seg.len() && out < need {
        let n = seg[i] as i8;
        i += 1;
        if n >= 0 {
            let run = n as usize + 1;
            if i + run > seg.len() {
                break;
            }
            i += run;
            out += run;
        } else if n != -128 {
            if i >= seg.len() {
                break;
            }
            i += 1;
            out += (1 - isize::from(n)) as usize;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packbits_counts_literal_and_repeat_runs() {
        // 3 literals, then 4 repeats of 9, then a no-op, then a truncated literal run.
        assert_eq!(packbits_len(&[2, 1, 2, 3, 0xFD, 9, 0x80, 5, 1], 100), 7);
        assert_eq!(packbits_len(&[2, 1, 2, 3], 2), 3);
    }

    #[test]
    fn rle_fragments_are_validated() {
        let mut frag = vec![0u8; 64];
        frag[0] = 1;
        frag[4] = 64;
        frag.extend([0xFD, 7]); // 4 × 7
        assert!(check_rle(std::slice::from_ref(&frag), 1, 1, 4).is_ok());
        assert!(check_rle(std::slice::from_ref(&frag), 1, 1, 5).unwrap_err().contains("decodes to 4"));
        assert!(check_rle(std::slice::from_ref(&frag), 2, 1, 4).unwrap_err().contains("fragment(s)"));
        assert!(check_rle(&[vec![1u8; 10]], 1, 1, 4).unwrap_err().contains("64-byte"));
        frag[4] = 200;
        assert!(check_rle(&[frag], 1, 1, 4).unwrap_err().contains("outside"));
    }
}
