//! The decoders of a bag's compressed chunks, in pure Rust: zstd (`ruzstd`) and lz4 frames
//! (`lz4_flex`), registered with the MCAP reader in place of the `mcap` crate's bindings to
//! the C libraries (whose C builds took about 27 s of a fresh build's 430 s of compilation,
//! issue 35). Memory-safe on a crafted chunk, and lazy: each asks the reader for the whole
//! compressed chunk (at most [`crate::MAX_BAG_RECORD_BYTES`], the reader's record limit)
//! and decodes it only as far as its output is taken.

use std::io::{Cursor, Read};

use mcap::sans_io::decompressor::{DecompressResult, Decompressor};
use mcap::{McapError, McapResult};

/// The codecs of the chunks a bag may hold, by their MCAP name.
#[derive(Debug, Clone, Copy)]
enum Codec {
    Zstd,
    Lz4,
}

/// One compressed chunk, read as its output is taken.
pub(crate) struct ChunkDecoder {
    codec: Codec,
    /// The chunk being decoded; `None` before its compressed bytes arrive.
    stream: Option<Box<dyn Read + Send>>,
}

impl ChunkDecoder {
    /// The decoder of `"zstd"` chunks (every frame in turn, skippable frames skipped).
    pub(crate) fn zstd() -> Self {
        ChunkDecoder {
            codec: Codec::Zstd,
            stream: None,
        }
    }

    /// The decoder of `"lz4"` chunks (LZ4 frames).
    pub(crate) fn lz4() -> Self {
        ChunkDecoder {
            codec: Codec::Lz4,
            stream: None,
        }
    }
}

impl Decompressor for ChunkDecoder {
    fn next_read_size(&self) -> usize {
        // The whole chunk first (the reader caps the request at the chunk's remaining bytes
        // and at its record limit), then nothing more.
        if self.stream.is_none() {
            usize::MAX
        } else {
            0
        }
    }

    fn decompress(&mut self, src: &[u8], dst: &mut [u8]) -> McapResult<DecompressResult> {
        let name = self.name();
        let mut consumed = 0;
        let stream = match &mut self.stream {
            Some(stream) => stream,
            None => {
                // The reader hands over every compressed byte the chunk has left: the hint
                // above is larger than any chunk it reads.
                consumed = src.len();
                let input = src.to_vec();
                self.stream.insert(match self.codec {
                    Codec::Zstd => Box::new(ZstdFrames::new(input)),
                    Codec::Lz4 => Box::new(Lz4Frames(lz4_flex::frame::FrameDecoder::new(
                        Cursor::new(input),
                    ))),
                })
            }
        };
        let wrote = loop {
            match stream.read(dst) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    return Err(McapError::DecompressionError(format!("{name} chunk: {e}")));
                }
            }
        };
        if wrote == 0 && consumed == 0 && !dst.is_empty() {
            return Err(McapError::DecompressionError(format!(
                "{name} chunk: its compressed data ends before its declared size"
            )));
        }
        Ok(DecompressResult { consumed, wrote })
    }

    fn reset(&mut self) -> McapResult<()> {
        self.stream = None;
        Ok(())
    }

    fn name(&self) -> &'static str {
        match self.codec {
            Codec::Zstd => "zstd",
            Codec::Lz4 => "lz4",
        }
    }
}

/// The LZ4 frames of one chunk in turn (the frame decoder reads 0 bytes at each frame's
/// end).
struct Lz4Frames(lz4_flex::frame::FrameDecoder<Cursor<Vec<u8>>>);

impl Read for Lz4Frames {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        loop {
            let at = self.0.get_ref().position();
            let n = self.0.read(out)?;
            let input = self.0.get_ref();
            let (moved, left) = (
                input.position() != at,
                input.position() < input.get_ref().len() as u64,
            );
            // A frame's end with more frames after it, or a read that made progress.
            if n > 0 || out.is_empty() || !left || !moved {
                return Ok(n);
            }
        }
    }
}

/// The zstd frames of one chunk, decoded in turn as they are read.
struct ZstdFrames {
    input: Vec<u8>,
    /// Bytes of `input` already taken by the decoder.
    at: usize,
    decoder: ruzstd::decoding::FrameDecoder,
    /// Whether a frame is open (its header read, its end not yet drained).
    in_frame: bool,
}

/// Most bytes decoded at once ahead of the reader. The decoder also keeps the frame's window
/// (at most 100 MB, ruzstd's limit, as zstd's own default of 128 MB): a chunk's memory is
/// bounded whatever it declares.
const ZSTD_STEP_BYTES: usize = 1 << 20;

impl ZstdFrames {
    fn new(input: Vec<u8>) -> Self {
        ZstdFrames {
            input,
            at: 0,
            decoder: ruzstd::decoding::FrameDecoder::new(),
            in_frame: false,
        }
    }
}

fn invalid(e: impl std::fmt::Display) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string())
}

impl Read for ZstdFrames {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        use ruzstd::decoding::errors::{FrameDecoderError, ReadFrameHeaderError};
        if out.is_empty() {
            return Ok(0);
        }
        loop {
            if self.in_frame {
                let n = self.decoder.read(out)?;
                if n > 0 {
                    return Ok(n);
                }
                if self.decoder.is_finished() {
                    self.in_frame = false;
                    continue;
                }
                let mut src = &self.input[self.at..];
                let before = src.len();
                self.decoder
                    .decode_blocks(
                        &mut src,
                        ruzstd::decoding::BlockDecodingStrategy::UptoBytes(ZSTD_STEP_BYTES),
                    )
                    .map_err(invalid)?;
                let taken = before - src.len();
                self.at += taken;
                // Every block takes bytes; none taken and the frame open: its input ended.
                if taken == 0 && !self.decoder.is_finished() {
                    return Err(invalid("a frame ends early"));
                }
                continue;
            }
            if self.at >= self.input.len() {
                return Ok(0);
            }
            let mut src = &self.input[self.at..];
            let before = src.len();
            match self.decoder.init(&mut src) {
                Ok(()) => {
                    self.at += before - src.len();
                    self.in_frame = true;
                }
                Err(FrameDecoderError::ReadFrameHeaderError(ReadFrameHeaderError::SkipFrame {
                    length,
                    ..
                })) => {
                    // The skippable frame's header is read; its content is passed over.
                    let end = self.at + (before - src.len()) + length as usize;
                    if end > self.input.len() {
                        return Err(invalid("a skippable frame runs past the chunk's end"));
                    }
                    self.at = end;
                }
                Err(e) => return Err(invalid(e)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first `len` bytes `d` decodes from `compressed`, taken `step` bytes at a time (as
    /// the reader takes them: it stops at the chunk's declared size).
    fn decode(
        mut d: ChunkDecoder,
        compressed: &[u8],
        step: usize,
        len: usize,
    ) -> McapResult<Vec<u8>> {
        let mut out = Vec::new();
        let first = d.decompress(compressed, &mut [])?;
        assert_eq!((first.consumed, first.wrote), (compressed.len(), 0));
        assert_eq!(d.next_read_size(), 0);
        while out.len() < len {
            let mut buf = vec![0; step.min(len - out.len())];
            let r = d.decompress(&[], &mut buf)?;
            out.extend_from_slice(&buf[..r.wrote]);
        }
        // Past the end: nothing more, said as an error.
        assert!(d.decompress(&[], &mut [0; 8]).is_err());
        Ok(out)
    }

    fn sample() -> Vec<u8> {
        (0..300_000u32)
            .flat_map(|i| ((i * 2_654_435_761) >> 7).to_le_bytes())
            .take(1_000_000)
            .collect()
    }

    #[test]
    fn zstd_frames_in_turn_with_a_skippable_frame_between() {
        let data = sample();
        let (a, b) = data.split_at(400_000);
        let level = ruzstd::encoding::CompressionLevel::Fastest;
        let mut chunk = ruzstd::encoding::compress_to_vec(a, level);
        // A skippable frame: magic 0x184D2A50, 4-byte length, content.
        chunk.extend_from_slice(&0x184D_2A50u32.to_le_bytes());
        chunk.extend_from_slice(&5u32.to_le_bytes());
        chunk.extend_from_slice(b"hello");
        chunk.extend(ruzstd::encoding::compress_to_vec(b, level));
        for step in [1, 7, 65_536] {
            let got = decode(ChunkDecoder::zstd(), &chunk, step, data.len()).unwrap();
            assert!(got == data, "step {step}: {} bytes", got.len());
        }
    }

    #[test]
    fn lz4_frames_in_turn() {
        let data = sample();
        let mut chunk = Vec::new();
        for part in data.chunks(600_000) {
            let mut w = lz4_flex::frame::FrameEncoder::new(Vec::new());
            std::io::Write::write_all(&mut w, part).unwrap();
            chunk.extend(w.finish().unwrap());
        }
        let got = decode(ChunkDecoder::lz4(), &chunk, 4096, data.len()).unwrap();
        assert!(got == data);
    }

    #[test]
    fn a_truncated_or_garbled_chunk_is_an_error_not_a_panic() {
        let data = sample();
        let z = ruzstd::encoding::compress_to_vec(
            &data[..],
            ruzstd::encoding::CompressionLevel::Fastest,
        );
        let mut w = lz4_flex::frame::FrameEncoder::new(Vec::new());
        std::io::Write::write_all(&mut w, &data).unwrap();
        let l = w.finish().unwrap();
        for (decoder, bytes) in [
            (ChunkDecoder::zstd as fn() -> ChunkDecoder, z),
            (ChunkDecoder::lz4, l),
        ] {
            let cut = &bytes[..bytes.len() / 2];
            assert!(decode(decoder(), cut, 65_536, data.len()).is_err());
            let mut garbled = bytes.clone();
            for b in garbled.iter_mut().skip(20).step_by(97) {
                *b ^= 0xA5;
            }
            // Garbled: an error, or fewer or other bytes, never a panic.
            let mut d = decoder();
            if d.decompress(&garbled, &mut []).is_ok() {
                let mut buf = vec![0; data.len()];
                let mut at = 0;
                while let Ok(r) = d.decompress(&[], &mut buf[at..]) {
                    at += r.wrote;
                    if r.wrote == 0 || at == buf.len() {
                        break;
                    }
                }
                assert!(buf != data);
            }
            assert!(decode(decoder(), b"not a frame at all", 16, 100).is_err());
        }
    }
}
