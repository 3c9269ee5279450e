//! One verdict style for every page (the comparison report, the stress map, the validation
//! report): a table whose cells say agree / differs (or holds / broken, pass / FAIL) with the
//! number that decided it and the tolerance it was judged by, coloured.

use super::{esc, md_cell};
use std::fmt::Write as _;

/// What a cell says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Within the tolerance (green).
    Agree,
    /// Beyond the tolerance (red).
    Differs,
    /// Beyond the tolerance, but a known and explained exception (amber).
    Known,
    /// A measurement with no tolerance (cost), or not applicable (grey).
    Info,
}

impl Verdict {
    pub fn class(self) -> &'static str {
        match self {
            Verdict::Agree => "v-agree",
            Verdict::Differs => "v-differs",
            Verdict::Known => "v-known",
            Verdict::Info => "v-info",
        }
    }
    /// Background colour (also used by SVG maps).
    pub fn fill(self) -> &'static str {
        match self {
            Verdict::Agree => "#cdeccd",
            Verdict::Differs => "#f6c5c5",
            Verdict::Known => "#f9e3a3",
            Verdict::Info => "#e8eaee",
        }
    }
}

/// One cell: the verdict, its word ("agrees", "holds", "pass") and the deciding number with
/// the tolerance ("0.3 ms ≤ 5 ms").
#[derive(Debug, Clone)]
pub struct VCell {
    pub verdict: Verdict,
    pub word: String,
    pub detail: String,
}

impl VCell {
    pub fn new(verdict: Verdict, word: &str, detail: impl Into<String>) -> VCell {
        VCell {
            verdict,
            word: word.to_string(),
            detail: detail.into(),
        }
    }
    pub fn html(&self) -> String {
        format!(
            "<td class=\"v {}\"><b>{}</b>{}</td>",
            self.verdict.class(),
            esc(&self.word),
            if self.detail.is_empty() {
                String::new()
            } else {
                format!("<br><small>{}</small>", esc(&self.detail))
            }
        )
    }
    pub fn md(&self) -> String {
        let mark = match self.verdict {
            Verdict::Agree => "✅",
            Verdict::Differs => "❌",
            Verdict::Known => "⚠️",
            Verdict::Info => "ℹ️",
        };
        md_cell(&if self.detail.is_empty() {
            format!("{mark} {}", self.word)
        } else {
            format!("{mark} {}: {}", self.word, self.detail)
        })
    }
}

/// The CSS of verdict tables (included in every page that has one).
pub const CSS: &str = "table.verdict{border-collapse:collapse;margin:0.4em 0 0.8em;font-size:0.86em}\
table.verdict th,table.verdict td{border:1px solid #bbb;padding:3px 7px;text-align:left;vertical-align:top}\
table.verdict th{background:#f2f2f2}td.v small{color:#333}td.v-agree{background:#cdeccd}\
td.v-differs{background:#f6c5c5}td.v-known{background:#f9e3a3}td.v-info{background:#e8eaee}\
.vlegend span{display:inline-block;padding:1px 8px;margin-right:6px;border:1px solid #bbb;font-size:0.85em}";

/// Rows of a verdict table: the row's header cells, then its verdict cells.
pub type Rows = Vec<(Vec<String>, Vec<VCell>)>;

/// A legend line for the verdict colours, with the words used on this page.
pub fn legend_html(words: &[(Verdict, &str)]) -> String {
    let mut s = String::from("<p class=\"vlegend\">");
    for (v, w) in words {
        let _ = write!(
            s,
            "<span style=\"background:{}\">{}</span>",
            v.fill(),
            esc(w)
        );
    }
    s.push_str("</p>\n");
    s
}

/// A verdict table: row header cells (plain text) then verdict cells.
pub fn table_html(id: &str, head: &[String], rows: &[(Vec<String>, Vec<VCell>)]) -> String {
    let mut s = format!("<table class=\"verdict\" id=\"{id}\"><thead><tr>");
    for h in head {
        let _ = write!(s, "<th>{}</th>", esc(h));
    }
    s.push_str("</tr></thead><tbody>\n");
    for (lead, cells) in rows {
        s.push_str("<tr>");
        for l in lead {
            let _ = write!(s, "<th>{}</th>", esc(l));
        }
        for c in cells {
            s.push_str(&c.html());
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody></table>\n");
    s
}

pub fn table_md(head: &[String], rows: &[(Vec<String>, Vec<VCell>)]) -> String {
    let mut s = format!(
        "| {} |\n|{}\n",
        head.iter()
            .map(|h| md_cell(h))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(head.len())
    );
    for (lead, cells) in rows {
        let mut r: Vec<String> = lead.iter().map(|l| md_cell(l)).collect();
        r.extend(cells.iter().map(|c| c.md()));
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    s.push('\n');
    s
}
