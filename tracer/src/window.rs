//! A pixel window of a frame (`render --crop`, EXR data windows, `merge`): the one type the
//! film, the output writers and the renderer share; no pixels of its own.

/// A pixel window of a frame: columns `x0..x1` and rows `y0..y1` (ends exclusive), rows
/// counted from the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Window {
    /// The whole of a `width × height` frame.
    pub fn full(width: u32, height: u32) -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// A window of a `width × height` frame; an error (saying why) when it is empty or
    /// reaches outside the frame.
    pub fn new([x0, y0, x1, y1]: [u32; 4], (width, height): (u32, u32)) -> Result<Window, String> {
        if x0 >= x1 || y0 >= y1 {
            return Err(format!(
                "the window {x0},{y0},{x1},{y1} is empty (it needs x0 < x1 and y0 < y1; the \
                 ends are exclusive)"
            ));
        }
        if x1 > width || y1 > height {
            return Err(format!(
                "the window {x0},{y0},{x1},{y1} reaches outside the {width}×{height} frame \
                 (the ends are exclusive: at most {width},{height})"
            ));
        }
        Ok(Window { x0, y0, x1, y1 })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// The number of pixels.
    pub fn pixels(&self) -> usize {
        self.width() as usize * self.height() as usize
    }
}

impl std::fmt::Display for Window {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}
