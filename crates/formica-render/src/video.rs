//! H.264 video in an MP4 file, streamed frame by frame: OpenH264 (compiled from its C++ source
//! by the `openh264` crate, no system library) encodes, the pure-Rust `mp4` crate muxes. Only the
//! frame being encoded and one index entry per frame are held, so memory stays flat whatever
//! the length.

use openh264::encoder::{
    Complexity, Encoder, EncoderConfig, FrameRate, FrameType, IntraFramePeriod, QpRange,
    RateControlMode, UsageType,
};
use openh264::formats::{RgbaSliceU8, YUVBuffer};
use openh264::OpenH264API;
use std::io::{Seek, Write};
use tiny_skia::Pixmap;

/// Ticks of the MP4 track clock per frame (the track's timescale is `fps` times this).
const TICKS_PER_FRAME: u32 = 1000;

/// Streams frames into an H.264 MP4 file. Frames must all have the size given to
/// [`Mp4Writer::new`], both even (H.264's 4:2:0 colour planes are half size).
pub struct Mp4Writer<W: Write + Seek> {
    enc: Encoder,
    mux: Option<mp4::Mp4Writer<W>>,
    /// Waits for the next frame, which tells whether it is the last one.
    pending: Option<(Vec<u8>, bool)>,
    yuv: YUVBuffer,
    out: Option<W>,
    width: u32,
    height: u32,
    fps: u32,
    hold_frames: u32,
    frames: usize,
    written: u64,
}

/// NAL units of an Annex B byte stream, without their start codes.
fn nal_units(stream: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut starts = Vec::new();
    let mut i = 0;
    while i + 3 <= stream.len() {
        if stream[i] == 0 && stream[i + 1] == 0 && stream[i + 2] == 1 {
            starts.push(i + 3);
            i += 3;
        } else {
            i += 1;
        }
    }
    let ends: Vec<usize> = starts
        .iter()
        .skip(1)
        .map(|&s| {
            // The next unit's start code (3 or 4 bytes) ends this one.
            let mut e = s - 3;
            while e > 0 && stream[e - 1] == 0 {
                e -= 1;
            }
            e
        })
        .chain(std::iter::once(stream.len()))
        .collect();
    starts
        .into_iter()
        .zip(ends)
        .filter(|(s, e)| e > s)
        .map(move |(s, e)| &stream[s..e])
}

impl<W: Write + Seek> Mp4Writer<W> {
    /// A writer of `width` x `height` frames at `fps` frames per second; the last frame is shown
    /// `hold_s` seconds (at least one frame's time).
    pub fn new(out: W, width: u32, height: u32, fps: u32, hold_s: f32) -> Result<Self, String> {
        if !width.is_multiple_of(2) || !height.is_multiple_of(2) || width < 16 || height < 16 {
            return Err(format!(
                "video frames must be even-sized and at least 16x16, got {width}x{height}"
            ));
        }
        if width > 3840 || height > 2160 {
            return Err(format!(
                "video frames of {width}x{height} exceed the encoder's 3840x2160"
            ));
        }
        if !(1..=120).contains(&fps) {
            return Err(format!("video frame rate must be 1 to 120, got {fps}"));
        }
        let config = EncoderConfig::new()
            .usage_type(UsageType::ScreenContentRealTime)
            // A fixed quantiser range instead of a bit rate: drawings compress well, and rate
            // control would need skipped frames.
            .rate_control_mode(RateControlMode::Off)
            .qp(QpRange::new(18, 30))
            .adaptive_quantization(false)
            .background_detection(false)
            .max_frame_rate(FrameRate::from_hz(fps as f32))
            .skip_frames(false)
            .complexity(Complexity::Low)
            .num_threads(1)
            // A key frame every 10 s of video, so that players can seek.
            .intra_frame_period(IntraFramePeriod::from_num_frames(10 * fps));
        let enc = Encoder::with_api_config(OpenH264API::from_source(), config)
            .map_err(|e| format!("H.264 encoder: {e}"))?;
        let hold_frames = ((hold_s.max(0.0) * fps as f32).round() as u32).max(1);
        Ok(Self {
            enc,
            mux: None,
            pending: None,
            yuv: YUVBuffer::new(width as usize, height as usize),
            out: Some(out),
            width,
            height,
            fps,
            hold_frames,
            frames: 0,
            written: 0,
        })
    }

    /// Adds one frame.
    pub fn push(&mut self, pm: &Pixmap) -> Result<(), String> {
        if pm.width() != self.width || pm.height() != self.height {
            return Err(format!(
                "video frame is {}x{}, expected {}x{}",
                pm.width(),
                pm.height(),
                self.width,
                self.height
            ));
        }
        // Frames are opaque, so tiny-skia's premultiplied RGBA is plain RGBA.
        self.yuv.read_rgba8(RgbaSliceU8::new(
            pm.data(),
            (self.width as usize, self.height as usize),
        ));
        let bits = self
            .enc
            .encode(&self.yuv)
            .map_err(|e| format!("H.264 encoder: {e}"))?;
        let sync = matches!(bits.frame_type(), FrameType::IDR | FrameType::I);
        let stream = bits.to_vec();
        if self.mux.is_none() {
            self.start(&stream)?;
        }
        let mut sample = Vec::with_capacity(stream.len() + 16);
        for nal in nal_units(&stream) {
            // Parameter sets live in the track header; samples carry the slices.
            if matches!(nal[0] & 0x1f, 7 | 8) {
                continue;
            }
            let len = u32::try_from(nal.len()).map_err(|_| "H.264 NAL unit too large")?;
            sample.extend_from_slice(&len.to_be_bytes());
            sample.extend_from_slice(nal);
        }
        if let Some(prev) = self.pending.replace((sample, sync)) {
            self.write(prev, TICKS_PER_FRAME)?;
        }
        self.frames += 1;
        Ok(())
    }

    /// Opens the MP4 track with the sequence and picture parameter sets of the first frame.
    fn start(&mut self, first: &[u8]) -> Result<(), String> {
        let (mut sps, mut pps) = (None, None);
        for nal in nal_units(first) {
            match nal[0] & 0x1f {
                7 if sps.is_none() => sps = Some(nal.to_vec()),
                8 if pps.is_none() => pps = Some(nal.to_vec()),
                _ => {}
            }
        }
        let (Some(sps), Some(pps)) = (sps, pps) else {
            return Err("H.264 encoder: the first frame has no parameter sets".into());
        };
        let brand = |s: &str| s.parse::<mp4::FourCC>().map_err(|e| format!("MP4: {e}"));
        let config = mp4::Mp4Config {
            major_brand: brand("isom")?,
            minor_version: 512,
            compatible_brands: vec![
                brand("isom")?,
                brand("iso2")?,
                brand("avc1")?,
                brand("mp41")?,
            ],
            timescale: 1000,
        };
        let out = self.out.take().ok_or("MP4: writer already started")?;
        let mut mux = mp4::Mp4Writer::write_start(out, &config).map_err(|e| format!("MP4: {e}"))?;
        let w = u16::try_from(self.width).map_err(|_| "MP4: width too large")?;
        let h = u16::try_from(self.height).map_err(|_| "MP4: height too large")?;
        mux.add_track(&mp4::TrackConfig {
            track_type: mp4::TrackType::Video,
            timescale: self.fps * TICKS_PER_FRAME,
            language: "und".into(),
            media_conf: mp4::MediaConfig::AvcConfig(mp4::AvcConfig {
                width: w,
                height: h,
                seq_param_set: sps,
                pic_param_set: pps,
            }),
        })
        .map_err(|e| format!("MP4: {e}"))?;
        self.mux = Some(mux);
        Ok(())
    }

    fn write(&mut self, (bytes, sync): (Vec<u8>, bool), duration: u32) -> Result<(), String> {
        let mux = self.mux.as_mut().ok_or("MP4: no track yet")?;
        mux.write_sample(
            1,
            &mp4::Mp4Sample {
                start_time: self.written,
                duration,
                rendering_offset: 0,
                is_sync: sync,
                bytes: bytes.into(),
            },
        )
        .map_err(|e| format!("MP4: {e}"))?;
        self.written += u64::from(duration);
        Ok(())
    }

    /// Frames added so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Writes the last frame and the index; returns the output.
    pub fn finish(mut self) -> Result<W, String> {
        let Some(last) = self.pending.take() else {
            return Err("a video needs at least one frame".into());
        };
        self.write(last, self.hold_frames * TICKS_PER_FRAME)?;
        let mut mux = self.mux.take().ok_or("MP4: no track yet")?;
        mux.write_end().map_err(|e| format!("MP4: {e}"))?;
        Ok(mux.into_writer())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiny_skia::Color;

    #[test]
    fn splits_annex_b_streams() {
        let s = [
            0, 0, 0, 1, 0x67, 1, 2, 0, 0, 1, 0x68, 3, 0, 0, 0, 1, 0x65, 4, 5,
        ];
        let units: Vec<&[u8]> = nal_units(&s).collect();
        assert_eq!(units, [&[0x67, 1, 2][..], &[0x68, 3], &[0x65, 4, 5]]);
    }

    #[test]
    fn writes_a_playable_mp4() {
        let mut w = Mp4Writer::new(std::io::Cursor::new(Vec::new()), 64, 48, 10, 1.0)
            .expect("encoder starts");
        for k in 0..25u8 {
            let mut pm = Pixmap::new(64, 48).expect("pixmap");
            pm.fill(Color::from_rgba8(10 * k, 100, 200 - 5 * k, 255));
            w.push(&pm).expect("frame encodes");
        }
        assert_eq!(w.frames(), 25);
        let bytes = w.finish().expect("finishes").into_inner();
        let len = bytes.len() as u64;
        let r = mp4::Mp4Reader::read_header(std::io::Cursor::new(bytes), len).expect("valid MP4");
        let track = r.tracks().get(&1).expect("one track");
        assert_eq!(track.media_type().ok(), Some(mp4::MediaType::H264));
        assert_eq!((track.width(), track.height()), (64, 48));
        assert_eq!(track.sample_count(), 25);
        // 24 frames of 0.1 s and the last held 1 s.
        assert_eq!(track.duration(), std::time::Duration::from_millis(3400));
    }

    #[test]
    fn frames_decode_to_what_was_drawn() {
        let mut w = Mp4Writer::new(std::io::Cursor::new(Vec::new()), 64, 48, 10, 1.0)
            .expect("encoder starts");
        let colors = [[200u8, 30, 30], [30, 160, 40], [40, 60, 220]];
        for c in colors {
            let mut pm = Pixmap::new(64, 48).expect("pixmap");
            pm.fill(Color::from_rgba8(c[0], c[1], c[2], 255));
            w.push(&pm).expect("frame encodes");
        }
        let bytes = w.finish().expect("finishes").into_inner();
        let len = bytes.len() as u64;
        let mut r =
            mp4::Mp4Reader::read_header(std::io::Cursor::new(bytes), len).expect("valid MP4");
        let (sps, pps) = {
            let t = r.tracks().get(&1).expect("track");
            (
                t.sequence_parameter_set().expect("sps").to_vec(),
                t.picture_parameter_set().expect("pps").to_vec(),
            )
        };
        let mut dec = openh264::decoder::Decoder::new().expect("decoder");
        let mut rgb = vec![0u8; 64 * 48 * 3];
        for (k, want) in colors.iter().enumerate() {
            let sample = r
                .read_sample(1, k as u32 + 1)
                .expect("reads")
                .expect("sample");
            // Back to Annex B, with the parameter sets first.
            let mut annex_b = Vec::new();
            if k == 0 {
                for ps in [&sps, &pps] {
                    annex_b.extend_from_slice(&[0, 0, 0, 1]);
                    annex_b.extend_from_slice(ps);
                }
            }
            let mut b = &sample.bytes[..];
            while b.len() >= 4 {
                let n = u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as usize;
                annex_b.extend_from_slice(&[0, 0, 0, 1]);
                annex_b.extend_from_slice(&b[4..4 + n]);
                b = &b[4 + n..];
            }
            let img = dec
                .decode(&annex_b)
                .expect("decodes")
                .expect("a picture per sample");
            img.write_rgb8(&mut rgb);
            let mid = (24 * 64 + 32) * 3;
            for ch in 0..3 {
                let d = (i32::from(rgb[mid + ch]) - i32::from(want[ch])).abs();
                assert!(d <= 12, "frame {k}: {:?} vs {want:?}", &rgb[mid..mid + 3]);
            }
        }
    }

    #[test]
    fn odd_sizes_are_refused() {
        assert!(Mp4Writer::new(std::io::Cursor::new(Vec::new()), 63, 48, 10, 1.0).is_err());
    }
}
