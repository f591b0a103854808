//! Tables of text cells: the one form of every tabular result, shown as fixed-width text on a
//! terminal ([`Table::text`]) and as an HTML table in a report ([`Table::block`]).

use crate::html::Block;
use std::fmt::Write as _;

/// A table: a caption, a header row and rows of formatted cells.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    /// What the table shows.
    pub caption: String,
    /// The column names, with units.
    pub header: Vec<String>,
    /// The rows, one cell a column.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with `caption` and the column names `header`.
    pub fn new(caption: &str, header: &[&str]) -> Table {
        Table {
            caption: caption.to_string(),
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Append a row of cells.
    pub fn push(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    /// The table for a terminal: the caption, then the header and the rows in columns two
    /// spaces apart, each as wide as its widest cell; the first column left-aligned, the others
    /// right-aligned; each line indented by two spaces.
    pub fn text(&self) -> String {
        let chars = |c: &String| c.chars().count();
        let widths: Vec<usize> = (0..self.header.len())
            .map(|j| {
                std::iter::once(&self.header[j])
                    .chain(self.rows.iter().filter_map(|r| r.get(j)))
                    .map(chars)
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let line = |cells: &[String]| {
            let mut s = String::from(" ");
            for (j, c) in cells.iter().enumerate() {
                let pad = " ".repeat(widths.get(j).copied().unwrap_or(0).saturating_sub(chars(c)));
                if j == 0 {
                    let _ = write!(s, " {c}{pad}");
                } else {
                    let _ = write!(s, "  {pad}{c}");
                }
            }
            s.trim_end().to_string() + "\n"
        };
        let mut s = format!("{}:\n", self.caption);
        s += &line(&self.header);
        for r in &self.rows {
            s += &line(r);
        }
        s
    }

    /// The table as a block of a report.
    pub fn block(&self) -> Block {
        Block::Table {
            caption: self.caption.clone(),
            header: self.header.clone(),
            rows: self.rows.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_as_wide_as_their_widest_cell() {
        let mut t = Table::new("Steps", &["step", "c12 (m⁵/(N·s))", "holds"]);
        t.push(vec!["1".into(), "1.2000e-10".into(), "no".into()]);
        t.push(vec!["10".into(), "8.4e-11".into(), "yes".into()]);
        assert_eq!(
            t.text(),
            "Steps:\n  step  c12 (m⁵/(N·s))  holds\n  1         1.2000e-10     no\n  10           8.4e-11    yes\n"
        );
        match t.block() {
            Block::Table { rows, .. } => assert_eq!(rows.len(), 2),
            _ => panic!("a table block"),
        }
    }
}

/// `text` broken into lines of at most `width` characters at spaces (a word longer than the
/// width is cut); at least one line.
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = vec![String::new()];
    for word in text.split_whitespace() {
        let mut word: Vec<char> = word.chars().collect();
        loop {
            let line = lines.last_mut().expect("at least one line");
            let used = line.chars().count();
            let need = word.len() + usize::from(used > 0);
            if used + need <= width {
                if used > 0 {
                    line.push(' ');
                }
                line.extend(word.iter());
                break;
            }
            if used > 0 {
                lines.push(String::new());
                continue;
            }
            // a word wider than a whole line: cut it
            let rest = word.split_off(width);
            line.extend(word.iter());
            lines.push(String::new());
            word = rest;
        }
    }
    if lines.len() > 1 && lines.last().is_some_and(String::is_empty) {
        lines.pop();
    }
    lines
}

/// Column widths for cells whose widest entries are `natural`, `gap` characters apart, within
/// `total` characters: the natural widths where they fit, else the widest column narrowed
/// step by step (to no less than 8).
pub fn fit_widths(natural: &[usize], gap: usize, total: usize) -> Vec<usize> {
    let mut w = natural.to_vec();
    let room = total.saturating_sub(gap * natural.len().saturating_sub(1));
    while w.iter().sum::<usize>() > room {
        let (i, &widest) = w
            .iter()
            .enumerate()
            .max_by_key(|(_, v)| **v)
            .expect("at least one column");
        if widest <= 8 {
            break;
        }
        w[i] = widest - 1;
    }
    w
}

/// Rows of cells as text within `total` characters: each cell wrapped to its column's width
/// ([`fit_widths`]), columns two spaces apart, left-aligned, a row as tall as its tallest cell.
pub fn wrapped_text(header: &[&str], rows: &[Vec<String>], total: usize) -> String {
    let natural: Vec<usize> = (0..header.len())
        .map(|j| {
            rows.iter()
                .map(|r| r[j].chars().count())
                .chain([header[j].chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let widths = fit_widths(&natural, 2, total);
    let mut out = String::new();
    let head: Vec<String> = header.iter().map(|h| h.to_string()).collect();
    for row in std::iter::once(&head).chain(rows) {
        let cells: Vec<Vec<String>> = row.iter().zip(&widths).map(|(c, &w)| wrap(c, w)).collect();
        let height = cells.iter().map(Vec::len).max().unwrap_or(1);
        for k in 0..height {
            let line: Vec<String> = cells
                .iter()
                .zip(&widths)
                .map(|(c, &w)| {
                    let text = c.get(k).map_or("", String::as_str);
                    format!("{text:<w$}")
                })
                .collect();
            let _ = writeln!(out, "{}", line.join("  ").trim_end());
        }
    }
    out
}

#[cfg(test)]
mod wrap_tests {
    use super::*;

    #[test]
    fn wrapped_lines_keep_every_word_within_the_width() {
        let text =
            "the article's is measured on the real rig; LTI model 13.31 mm, emulated rig 13.15 mm";
        for width in [8, 20, 40] {
            let lines = wrap(text, width);
            assert!(
                lines.iter().all(|l| l.chars().count() <= width),
                "{lines:?}"
            );
            if width >= 9 {
                // no word is cut: the lines join back to the text
                assert_eq!(lines.join(" "), text);
            }
        }
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap("", 5), [""]);
    }

    #[test]
    fn a_wide_table_fits_its_width() {
        let rows = vec![vec![
            "a long quantity name with a unit (mm)".repeat(3),
            "1.0".into(),
        ]];
        let text = wrapped_text(&["quantity", "value"], &rows, 40);
        assert!(text.lines().all(|l| l.chars().count() <= 40), "{text}");
        assert!(text.contains("1.0"));
    }
}
