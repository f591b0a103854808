//! Curves at sub-pixel precision. Plotters writes SVG coordinates as whole pixels (kinks on
//! smooth curves), so a curve is drawn as a placeholder text ([`hold`]) and its exact SVG
//! element is written in its place once the document is finished ([`substitute`]). The
//! elements wait in a per-thread list between [`reset`] and [`substitute`] (one rendering at a
//! time per thread).

thread_local! {
    /// SVG elements waiting to replace their placeholders in the document being rendered.
    static PRECISE: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Prefix of the placeholder text standing for an element until [`substitute`].
const PLACEHOLDER: &str = "pumpcyl-precise-path-";

/// Forget the elements of an earlier, unfinished rendering (call before drawing).
pub(super) fn reset() {
    PRECISE.with(|p| p.borrow_mut().clear());
}

/// Keep `element` for [`substitute`]; the placeholder text to draw in its place.
pub(super) fn hold(element: String) -> String {
    let k = PRECISE.with(|p| {
        let mut p = p.borrow_mut();
        p.push(element);
        p.len() - 1
    });
    format!("{PLACEHOLDER}{k}")
}

/// `v` with at most two decimals, trailing zeros removed.
pub(super) fn short_decimal(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// `svg` with the placeholder texts of [`hold`] replaced by their elements.
pub(super) fn substitute(svg: String) -> String {
    let paths = PRECISE.with(|p| std::mem::take(&mut *p.borrow_mut()));
    if paths.is_empty() {
        return svg;
    }
    let mut out = String::with_capacity(svg.len() + paths.iter().map(String::len).sum::<usize>());
    let mut rest = svg.as_str();
    while let Some(at) = rest.find(PLACEHOLDER) {
        let start = rest[..at].rfind("<text").unwrap_or(at);
        let digits = &rest[at + PLACEHOLDER.len()..];
        let n_len = digits
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(digits.len());
        let k: Option<usize> = digits[..n_len].parse().ok();
        let end = rest[at..]
            .find("</text>")
            .map_or(rest.len(), |e| at + e + "</text>".len());
        out.push_str(&rest[..start]);
        if let Some(path) = k.and_then(|k| paths.get(k)) {
            out.push_str(path);
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}
