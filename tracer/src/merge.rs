//! Assembling region renders into the full frame (`shadenet merge`): the parts must share
//! one frame size and one set of channels and tile the frame exactly — no gap, no overlap.
//! It owns those checks and the copy; reading and writing the files is [`crate::output`]'s.

use crate::output::{Channel, ExrImage};
use crate::window::Window;
use std::path::PathBuf;

/// The full frame from its parts, each named by its file for the errors: every pixel comes
/// from the one part whose window holds it, bit for bit. Errors name the files: parts of
/// different frame sizes or channels, two parts that overlap (and where), pixels no part
/// covers (how many, and the first).
pub fn merge(parts: &[(PathBuf, ExrImage)]) -> Result<ExrImage, String> {
    let Some((first_path, first)) = parts.first() else {
        return Err("no parts to merge".into());
    };
    let names = |i: &ExrImage| i.channels.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
    let channels = names(first);
    for (path, part) in parts {
        let w = part.window;
        let sized = part.channels.iter().all(|c| c.1.len() == w.pixels());
        if w.pixels() == 0 || w.x1 > part.frame.0 || w.y1 > part.frame.1 || !sized {
            return Err(format!(
                "{}: its window {w} is empty, outside its {}×{} frame or not the size of \
                 its channels",
                path.display(),
                part.frame.0,
                part.frame.1
            ));
        }
    }
    for (path, part) in &parts[1..] {
        if part.frame != first.frame {
            return Err(format!(
                "{} is a part of a {}×{} frame, {} of a {}×{} frame",
                path.display(),
                part.frame.0,
                part.frame.1,
                first_path.display(),
                first.frame.0,
                first.frame.1
            ));
        }
        if names(part) != channels {
            return Err(format!(
                "{} has the channels [{}], {} has [{}]",
                path.display(),
                names(part).join(", "),
                first_path.display(),
                channels.join(", ")
            ));
        }
    }
    let full = Window::full(first.frame.0, first.frame.1);
    // The parts' pixels add up to the frame's exactly when nothing is missing and nothing
    // overlaps; counting first keeps a hostile display window from sizing an allocation.
    let covered: u64 = parts.iter().map(|(_, p)| p.window.pixels() as u64).sum();
    if covered < full.pixels() as u64 {
        return Err(gap_error(parts, full, covered));
    }
    let owner = owners(parts, full)?;
    if let Some(first_gap) = owner.iter().position(|&o| o == NONE) {
        let missing = owner.iter().filter(|&&o| o == NONE).count();
        return Err(format!(
            "the parts leave {missing} pixel(s) of the {}×{} frame uncovered, the first at \
             ({}, {})",
            full.x1,
            full.y1,
            first_gap % full.x1 as usize,
            first_gap / full.x1 as usize
        ));
    }
    let mut out: Vec<Channel> = channels
        .iter()
        .map(|n| (n.clone(), vec![0.0f32; full.pixels()]))
        .collect();
    for (_, part) in parts {
        let w = part.window;
        for (dst, (_, src)) in out.iter_mut().zip(&part.channels) {
            for (row, line) in src.chunks_exact(w.width() as usize).enumerate() {
                let at = (w.y0 as usize + row) * full.x1 as usize + w.x0 as usize;
                dst.1[at..at + line.len()].copy_from_slice(line);
            }
        }
    }
    Ok(ExrImage {
        width: full.x1,
        height: full.y1,
        window: full,
        frame: first.frame,
        channels: out,
    })
}

/// No part owns the pixel.
const NONE: u32 = u32::MAX;

/// Which part covers each pixel of the frame; an error naming both files where two parts
/// overlap.
fn owners(parts: &[(PathBuf, ExrImage)], full: Window) -> Result<Vec<u32>, String> {
    let mut owner = vec![NONE; full.pixels()];
    for (k, (path, part)) in parts.iter().enumerate() {
        let w = part.window;
        for y in w.y0..w.y1 {
            for x in w.x0..w.x1 {
                let at = y as usize * full.x1 as usize + x as usize;
                if owner[at] != NONE {
                    let other = &parts[owner[at] as usize];
                    return Err(format!(
                        "{} (window {}) and {} (window {}) overlap, first at pixel ({x}, {y})",
                        other.0.display(),
                        other.1.window,
                        path.display(),
                        w
                    ));
                }
                owner[at] = k as u32;
            }
        }
    }
    Ok(owner)
}

/// The error for parts whose `covered` pixels do not add up to the frame: the windows they
/// have.
fn gap_error(parts: &[(PathBuf, ExrImage)], full: Window, covered: u64) -> String {
    let list: Vec<String> = parts
        .iter()
        .map(|(p, i)| format!("{} {}", p.display(), i.window))
        .collect();
    format!(
        "the parts cover {covered} of the {}×{} frame's {} pixels: some are missing (windows: \
         {})",
        full.x1,
        full.y1,
        full.pixels(),
        list.join("; ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A part of a 4×3 frame: channel `c.R` holds each pixel's index in the full frame.
    fn part(name: &str, x0: u32, y0: u32, x1: u32, y1: u32) -> (PathBuf, ExrImage) {
        let window = Window { x0, y0, x1, y1 };
        let data = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (y * 4 + x) as f32))
            .collect();
        let image = ExrImage {
            width: window.width(),
            height: window.height(),
            window,
            frame: (4, 3),
            channels: vec![("c.R".into(), data)],
        };
        (PathBuf::from(name), image)
    }

    #[test]
    fn parts_that_tile_the_frame_assemble_it() {
        let parts = [
            part("a.exr", 0, 0, 4, 1),
            part("b.exr", 0, 1, 3, 3),
            part("c.exr", 3, 1, 4, 3),
        ];
        let full = merge(&parts).unwrap();
        assert_eq!((full.width, full.height), (4, 3));
        assert_eq!(full.window, Window::full(4, 3));
        let want: Vec<f32> = (0..12).map(|i| i as f32).collect();
        assert_eq!(full.channels, vec![("c.R".to_string(), want)]);
    }

    #[test]
    fn gaps_overlaps_and_mismatches_are_errors_naming_the_files() {
        let gap = merge(&[part("a.exr", 0, 0, 4, 1), part("b.exr", 0, 1, 4, 2)]).unwrap_err();
        assert!(
            gap.contains("cover 8 of the 4×3 frame's 12 pixels"),
            "{gap}"
        );
        assert!(gap.contains("b.exr 0,1,4,2"), "{gap}");
        // As many pixels as the frame, but two parts share a row and one row is missing.
        let overlap = merge(&[
            part("a.exr", 0, 0, 4, 2),
            part("b.exr", 0, 1, 4, 2),
            part("c.exr", 0, 1, 4, 2),
        ])
        .unwrap_err();
        assert!(
            overlap.contains("a.exr (window 0,0,4,2) and b.exr (window 0,1,4,2) overlap")
                && overlap.contains("pixel (0, 1)"),
            "{overlap}"
        );
        let mut other = part("b.exr", 0, 1, 4, 3);
        other.1.frame = (4, 4);
        let frames = merge(&[part("a.exr", 0, 0, 4, 1), other]).unwrap_err();
        assert!(
            frames.contains("b.exr is a part of a 4×4 frame, a.exr of a 4×3"),
            "{frames}"
        );
        let mut renamed = part("b.exr", 0, 1, 4, 3);
        renamed.1.channels[0].0 = "c.G".into();
        let names = merge(&[part("a.exr", 0, 0, 4, 1), renamed]).unwrap_err();
        assert!(names.contains("b.exr has the channels [c.G]"), "{names}");
        assert_eq!(merge(&[]).unwrap_err(), "no parts to merge");
    }
}
