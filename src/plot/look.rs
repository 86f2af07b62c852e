//! How a series looks: its colour, marker shape and dash pattern, from its palette index.
//!
//! The colours are Okabe and Ito's palette for colour-blind readers ("Color Universal Design",
//! 2002), without its yellow (too pale on white), black first: seven colours that stay distinct
//! under the common colour-vision deficiencies. From the eighth series on, the colours repeat
//! with another marker shape and another dash pattern, so that no two of the first 35 marker
//! series (7 colours × 5 shapes) and no two of the first 35 line series look alike.

use plotters::style::RGBColor;

/// The palette index of neutral grey, outside the series' colours: reference lines, stage
/// marks, shaded spans ([`super::Series::with_color`]).
pub const GREY: usize = usize::MAX;

/// Okabe–Ito: black, blue, vermillion, bluish green, reddish purple, orange, sky blue.
const COLORS: [RGBColor; 7] = [
    RGBColor(0, 0, 0),
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

const GREY_RGB: RGBColor = RGBColor(128, 128, 128);

/// The colours before they repeat.
pub const COLOR_COUNT: usize = COLORS.len();

/// A marker's outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A circle.
    Circle,
    /// A square on its side.
    Square,
    /// A triangle pointing up.
    TriangleUp,
    /// A square on its corner.
    Diamond,
    /// A triangle pointing down.
    TriangleDown,
}

const SHAPES: [Shape; 5] = [
    Shape::Circle,
    Shape::Square,
    Shape::TriangleUp,
    Shape::Diamond,
    Shape::TriangleDown,
];

/// Dash patterns in pixels at the design size (700 px on the short side): on, off, on, off, ...
/// The empty pattern is a solid line.
const DASHES: [&[f64]; 5] = [
    &[],
    &[9.0, 6.0],
    &[2.0, 4.0],
    &[10.0, 4.0, 2.0, 4.0],
    &[18.0, 6.0],
];

/// Colour, marker shape and dash pattern of one series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Look {
    /// Stroke and fill colour.
    pub color: RGBColor,
    /// Marker outline.
    pub shape: Shape,
    /// Dash pattern of its line at the design size (empty: solid).
    pub dash: &'static [f64],
}

/// The look of palette index `index`, for a line that is `dashed` by its style: the colour
/// cycles through the palette; each further cycle takes the next marker shape and dash pattern
/// (a dashed style never gets the solid pattern). [`GREY`] is grey, circles, solid (dashed when
/// `dashed`).
pub fn look(index: usize, dashed: bool) -> Look {
    if index == GREY {
        return Look {
            color: GREY_RGB,
            shape: Shape::Circle,
            dash: DASHES[usize::from(dashed)],
        };
    }
    let cycle = index / COLORS.len();
    let dash = if dashed {
        DASHES[1 + cycle % (DASHES.len() - 1)]
    } else {
        DASHES[cycle % DASHES.len()]
    };
    Look {
        color: COLORS[index % COLORS.len()],
        shape: SHAPES[cycle % SHAPES.len()],
        dash,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_35_markers_and_lines_all_differ() {
        for dashed in [false, true] {
            let looks: Vec<Look> = (0..35).map(|i| look(i, dashed)).collect();
            for i in 0..looks.len() {
                for j in 0..i {
                    let (a, b) = (looks[i], looks[j]);
                    assert!(a.color != b.color || a.shape != b.shape, "markers {i} {j}");
                    // Lines: colour or dash pattern; five patterns for lines, four when dashed.
                    if !dashed || (i / 7) % 4 != (j / 7) % 4 {
                        assert!(a.color != b.color || a.dash != b.dash, "lines {i} {j}");
                    }
                }
            }
        }
        assert!(
            look(3, true).dash.len() >= 2,
            "a dashed style is never solid"
        );
        let grey = look(GREY, false).color;
        assert_eq!((grey.0, grey.1, grey.2), (128, 128, 128));
    }
}
