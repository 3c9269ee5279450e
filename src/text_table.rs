//! Plain-text tables for the terminal: columns left-aligned to their widest cell (in
//! characters), two spaces apart, each line's trailing spaces trimmed.

/// The header line and one line per row (each row as many cells as the head, or fewer), each
/// ending in a newline.
pub fn aligned<H: AsRef<str>, C: AsRef<str>>(head: &[H], rows: &[Vec<C>]) -> String {
    let mut widths: Vec<usize> = head.iter().map(|h| h.as_ref().chars().count()).collect();
    for row in rows {
        for (width, cell) in widths.iter_mut().zip(row) {
            *width = (*width).max(cell.as_ref().chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .map(|(c, &width)| format!("{c:<width$}"))
            .collect();
        padded.join("  ").trim_end().to_string() + "\n"
    };
    let mut out = line(head.iter().map(AsRef::as_ref).collect());
    for row in rows {
        out += &line(row.iter().map(AsRef::as_ref).collect());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::aligned;

    #[test]
    fn columns_align_on_their_widest_cell_counted_in_characters() {
        let s = |v: &[&str]| v.iter().map(|c| c.to_string()).collect::<Vec<_>>();
        let table = aligned(
            &s(&["case", "phi"]),
            &[s(&["two-block", "1e-3"]), s(&["µ-test", ""])],
        );
        assert_eq!(
            table, "case       phi\ntwo-block  1e-3\nµ-test\n",
            "{table}"
        );
    }
}
