//! The label map as the shaders read it: per voxel its label's table entry, opacity-premultiplied
//! (`[a·r, a·g, a·b, a]`, `a` 0 for a hidden label), in half floats, so that ONE trilinear fetch
//! gives the opacity-weighted blend of the 8 neighbouring labels (docs/labels.md). Rebuilt on the
//! host whenever the table, the hidden labels or the mode change.

use super::label_settings::{LabelMode, LabelSettings};
use crate::volume::optics::label_table::{LabelTable, LABELS};

/// Bytes per voxel of the colour texture (RGBA16F).
pub const COLOUR_BYTES: u64 = 8;
/// Bytes per voxel of the keep texture (R16F), present in `replace` mode only.
pub const KEEP_BYTES: u64 = 2;

/// `x` (finite, in [0, 65504]) as IEEE half-float bits, rounded to nearest, ties to even.
pub fn f16_bits(x: f32) -> u16 {
    let e = ((x.to_bits() >> 23) & 0xff) as i32 - 127;
    if e < -14 {
        // Subnormal halves are multiples of 2^-24; the scaling is exact in f32.
        return (x * 16_777_216.0).round_ties_even() as u16;
    }
    // 11 significant bits; a mantissa rounding up to 2048 carries into the exponent.
    let m = (x * 2f32.powi(10 - e)).round_ties_even() as u32;
    (((e + 15) as u32) << 10).wrapping_add(m).wrapping_sub(1024) as u16
}

/// Per label value: the colour texel (`[a·rgb, a]` as half bits; in `replace` mode label 0's
/// colour is 0, the medium's colour enters through the keep weight) and the keep weight (label
/// 0's opacity in `replace` mode, else 0).
fn entries(table: &LabelTable, s: &LabelSettings) -> ([[u16; 4]; LABELS], [u16; LABELS]) {
    let mut colour = [[0u16; 4]; LABELS];
    let mut keep = [0u16; LABELS];
    for (l, e) in table.entries.iter().enumerate().take(LABELS) {
        let a = match s.opacity[l] {
            _ if s.is_hidden(l as u32) => 0.0,
            set if set >= 0.0 => set,
            _ => e[3],
        };
        let keeps = s.mode == LabelMode::Replace && l == 0;
        let rgb = if keeps { [0.0; 3] } else { [e[0], e[1], e[2]] };
        colour[l] = [f16_bits(a * rgb[0]), f16_bits(a * rgb[1]), f16_bits(a * rgb[2]), f16_bits(a)];
        keep[l] = if keeps { f16_bits(a) } else { 0 };
    }
    (colour, keep)
}

/// The colour texture's bytes for `labels` (one label per voxel) and, in `replace` mode, the keep
/// texture's.
pub fn build(labels: &[u8], table: &LabelTable, s: &LabelSettings) -> (Vec<u8>, Option<Vec<u8>>) {
    let (colour, keep) = entries(table, s);
    let mut c = Vec::with_capacity(labels.len() * COLOUR_BYTES as usize);
    for &l in labels {
        c.extend(colour[l as usize].iter().flat_map(|h| h.to_le_bytes()));
    }
    let k =
        (s.mode == LabelMode::Replace).then(|| labels.iter().flat_map(|&l| keep[l as usize].to_le_bytes()).collect());
    (c, k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_match_ieee_754() {
        // Bit patterns from the IEEE 754 binary16 definition (independent of the conversion).
        for (x, bits) in [
            (0.0, 0x0000),
            (1.0, 0x3c00),
            (0.5, 0x3800),
            (0.25, 0x3400),
            (0.1, 0x2e66),
            (0.3, 0x34cd),
            (0.999_9, 0x3c00),
            (2f32.powi(-14), 0x0400),
            (2f32.powi(-24), 0x0001),
            (2f32.powi(-15), 0x0200),
            (65504.0, 0x7bff),
        ] {
            assert_eq!(f16_bits(x), bits, "{x}");
        }
        // A tie (1 + 2^-11, halfway between 1 and 1 + 2^-10) rounds to the even mantissa.
        assert_eq!(f16_bits(1.0 + 2f32.powi(-11)), 0x3c00);
        assert_eq!(f16_bits(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02);
    }

    #[test]
    fn texels_are_premultiplied_and_hidden_labels_are_empty() {
        let mut t = LabelTable::default();
        t.entries[1] = [1.0, 0.5, 0.25, 0.5];
        let mut s = LabelSettings::default();
        s.hidden[0] = 1 << 2;
        let (c, k) = build(&[1, 2, 0], &t, &s);
        let h = |i: usize| u16::from_le_bytes([c[2 * i], c[2 * i + 1]]);
        assert_eq!([h(0), h(1), h(2), h(3)], [0x3800, 0x3400, 0x3000, 0x3800]);
        assert_eq!([h(4), h(5), h(6), h(7)], [0; 4]);
        assert_eq!([h(8), h(9), h(10), h(11)], [0x3c00; 4]);
        assert!(k.is_none());
        s.mode = LabelMode::Replace;
        let (c, k) = build(&[0, 1], &t, &s);
        assert_eq!(&c[..8], &[0, 0, 0, 0, 0, 0, 0x00, 0x3c]);
        assert_eq!(k.expect("replace keeps label 0"), vec![0x00, 0x3c, 0, 0]);
    }
}
