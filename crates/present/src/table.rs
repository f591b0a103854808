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
