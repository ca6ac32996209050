//! Decoding Blosc-1 buffers, as OpenVDB writes them (LZ4 or zlib inside, byte shuffle).
//!
//! Layout (c-blosc 1.x): a 16-byte header (version, codec version, flags, type size, uncompressed
//! size, block size, compressed size), then either the raw bytes (flag "memcpyed") or one start offset
//! per block followed by the blocks; each block holds `typesize` split streams (one unless the
//! "don't split" flag is set or it is the short last block), each an `i32` length and an LZ4 / zlib
//! stream, or the raw stream when the length equals the stream size.

use std::io::Read;

const SHUFFLE: u8 = 0x01;
const MEMCPYED: u8 = 0x02;
const BIT_SHUFFLE: u8 = 0x04;
const DONT_SPLIT: u8 = 0x10;

fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4)
        .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        .ok_or_else(|| "Blosc buffer truncated".to_owned())
}

/// Decompresses one Blosc buffer that must expand to exactly `expected` bytes.
pub(crate) fn decompress(src: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    if src.len() < 16 {
        return Err(format!("Blosc buffer of {} bytes is shorter than its header", src.len()));
    }
    let flags = src[2];
    let typesize = usize::from(src[3]).max(1);
    let nbytes = u32_at(src, 4)? as usize;
    let blocksize = u32_at(src, 8)? as usize;
    let cbytes = u32_at(src, 12)? as usize;
    if nbytes != expected {
        return Err(format!("Blosc buffer holds {nbytes} bytes, the node needs {expected}"));
    }
    if cbytes > src.len() {
        return Err(format!("Blosc buffer says {cbytes} bytes but {} are stored", src.len()));
    }
    let src = &src[..cbytes];
    if flags & MEMCPYED != 0 {
        return src.get(16..16 + nbytes).map(<[u8]>::to_vec).ok_or_else(|| "Blosc raw buffer truncated".to_owned());
    }
    if flags & BIT_SHUFFLE != 0 {
        return Err("Blosc bit-shuffle is not supported".into());
    }
    let codec = flags >> 5;
    if codec != 1 && codec != 3 {
        let name = ["blosclz", "lz4", "snappy", "zlib", "zstd"].get(usize::from(codec)).copied().unwrap_or("unknown");
        return Err(format!("Blosc codec {name} is not supported (LZ4 and zlib are)"));
    }
    if nbytes == 0 {
        return Ok(Vec::new());
    }
    if blocksize == 0 {
        return Err("Blosc block size is 0".into());
    }
    let nblocks = nbytes.div_ceil(blocksize);
    let leftover = nbytes % blocksize;
    let mut out = vec![0u8; nbytes];
    let mut block = vec![0u8; blocksize.min(nbytes)];
    for b in 0..nblocks {
        let last_short = b == nblocks - 1 && leftover > 0;
        let bsize = if last_short { leftover } else { blocksize };
        let nsplits = if flags & DONT_SPLIT != 0 || last_short { 1 } else { typesize };
        let split = bsize / nsplits;
        if split * nsplits != bsize {
            return Err("Blosc block does not divide into its streams".into());
        }
        let mut at = u32_at(src, 16 + 4 * b)? as usize;
        for s in 0..nsplits {
            let len = u32_at(src, at)? as usize;
            at += 4;
            let stream = src.get(at..at + len).ok_or("Blosc stream runs past the buffer")?;
            let dst = &mut block[s * split..(s + 1) * split];
            if len == split {
                dst.copy_from_slice(stream);
            } else if codec == 1 {
                let n = lz4_flex::block::decompress_into(stream, dst).map_err(|e| format!("LZ4: {e}"))?;
                if n != split {
                    return Err(format!("LZ4 stream gave {n} bytes, expected {split}"));
                }
            } else {
                let mut z = flate2::read::ZlibDecoder::new(stream);
                z.read_exact(dst).map_err(|e| format!("zlib: {e}"))?;
            }
            at += len;
        }
        let dst = &mut out[b * blocksize..b * blocksize + bsize];
        if flags & SHUFFLE != 0 && typesize > 1 {
            // Byte shuffle stores byte j of every element together; the tail that does not fill an
            // element is left as is.
            let n = bsize / typesize;
            for i in 0..n {
                for j in 0..typesize {
                    dst[i * typesize + j] = block[j * n + i];
                }
            }
            dst[n * typesize..].copy_from_slice(&block[n * typesize..bsize]);
        } else {
            dst.copy_from_slice(&block[..bsize]);
        }
    }
    Ok(out)
}
