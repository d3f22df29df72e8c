//! Animation output for the CLI: GIF and APNG writers fed frame by frame, and a progress
//! line on stderr.

use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The optional GIF and APNG files of an animation, written under `.partial` names and
/// renamed by `finish`; dropped unfinished (a failed render), they remove their files.
pub struct Sinks {
    gif: Option<image::codecs::gif::GifEncoder<BufWriter<File>>>,
    apng: Option<png::Writer<BufWriter<File>>>,
    fps: u32,
    /// (temporary, final) names of the files being written.
    files: Vec<(PathBuf, PathBuf)>,
}

impl Sinks {
    pub fn new(
        gif: Option<&Path>,
        apng: Option<&Path>,
        size: (u32, u32),
        frames: u32,
        fps: u32,
    ) -> Result<Sinks> {
        let mut files = Vec::new();
        let mut create = |p: &Path| -> Result<File> {
            let tmp = crate::output::partial(p);
            let f = File::create(&tmp).with_context(|| format!("creating {}", p.display()))?;
            files.push((tmp, p.to_path_buf()));
            Ok(f)
        };
        let gif = match gif {
            Some(p) => {
                let f = create(p)?;
                let mut e = image::codecs::gif::GifEncoder::new_with_speed(BufWriter::new(f), 10);
                e.set_repeat(image::codecs::gif::Repeat::Infinite)?;
                Some(e)
            }
            None => None,
        };
        let apng = match apng {
            Some(p) => {
                let f = create(p)?;
                let mut e = png::Encoder::new(BufWriter::new(f), size.0, size.1);
                e.set_color(png::ColorType::Rgba);
                e.set_depth(png::BitDepth::Eight);
                e.set_animated(frames, 0)?;
                e.set_frame_delay(1, fps as u16)?;
                Some(e.write_header()?)
            }
            None => None,
        };
        Ok(Sinks {
            gif,
            apng,
            fps,
            files,
        })
    }

    pub fn push(&mut self, img: &image::RgbaImage) -> Result<()> {
        if let Some(g) = &mut self.gif {
            let delay = image::Delay::from_numer_denom_ms(1000, self.fps);
            g.encode_frame(image::Frame::from_parts(img.clone(), 0, 0, delay))?;
        }
        if let Some(a) = &mut self.apng {
            a.write_image_data(img.as_raw())?;
        }
        Ok(())
    }

    pub fn finish(mut self) -> Result<()> {
        if let Some(a) = self.apng.take() {
            a.finish()?;
        }
        // Dropping the GIF encoder writes its trailer and flushes the file.
        drop(self.gif.take());
        for (tmp, path) in std::mem::take(&mut self.files) {
            std::fs::rename(&tmp, &path).with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }
}

impl Drop for Sinks {
    fn drop(&mut self) {
        for (tmp, _) in &self.files {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// "[=====>     ] 12/40 frames  0.31 s/frame  ETA 9 s" on stderr, redrawn in place.
pub struct Progress {
    total: u32,
    done: u32,
    start: Instant,
}

impl Progress {
    pub fn new(total: u32) -> Progress {
        Progress {
            total,
            done: 0,
            start: Instant::now(),
        }
    }

    pub fn tick(&mut self) {
        self.done += 1;
        let per = self.start.elapsed().as_secs_f64() / self.done as f64;
        let width = 30usize;
        let filled = (self.done as usize * width) / self.total.max(1) as usize;
        let bar: String = (0..width)
            .map(|i| {
                if i < filled {
                    '='
                } else if i == filled {
                    '>'
                } else {
                    ' '
                }
            })
            .collect();
        let eta = per * (self.total - self.done) as f64;
        let mut err = std::io::stderr();
        let _ = write!(
            err,
            "\r[{bar}] {}/{} frames  {per:.2} s/frame  ETA {eta:.0} s ",
            self.done, self.total
        );
        let _ = err.flush();
    }

    pub fn done(&self) {
        eprintln!();
    }
}
