//! A small HTML document builder: one self-contained, printable file.

use std::fmt::Write;

use super::chart::Chart;
use super::format::{escape, fmt_num};

/// Inline style: light, readable on screen and on paper; no external fonts.
const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;color:#1a1a1a;\
background:#ffffff;max-width:960px;margin:2em auto;padding:0 1em;line-height:1.45}\
h1{font-size:1.6em;border-bottom:2px solid #0072B2;padding-bottom:.2em}\
h2{font-size:1.25em;margin-top:1.8em}\
table{border-collapse:collapse;margin:.8em 0;font-size:.9em}\
caption{text-align:left;font-weight:bold;padding:.3em 0}\
th,td{border:1px solid #cccccc;padding:.25em .6em}\
th{background:#f2f2f2}td.num{text-align:right;font-variant-numeric:tabular-nums}\
figure{margin:1em 0}figcaption{font-size:.9em;color:#444444}svg{max-width:100%;height:auto}\
pre{background:#f7f7f7;border:1px solid #dddddd;padding:.6em;overflow-x:auto;font-size:.85em}\
.how{background:#f4f8fb;border-left:4px solid #0072B2;padding:.4em 1em;margin:1em 0}\
@media print{body{margin:0;max-width:none}figure,table{break-inside:avoid}}";

/// One table cell: text, or a number printed with a fixed number of decimals (non-finite prints `—`).
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    Text(String),
    Num(f64, usize),
}

impl From<&str> for Cell {
    fn from(text: &str) -> Self {
        Cell::Text(text.to_string())
    }
}

impl From<String> for Cell {
    fn from(text: String) -> Self {
        Cell::Text(text)
    }
}

/// A table with a header row and an optional caption.
#[derive(Debug, Clone, Default)]
pub struct Table {
    caption: Option<String>,
    header: Vec<String>,
    rows: Vec<Vec<Cell>>,
}

impl Table {
    pub fn new<S: AsRef<str>>(header: &[S]) -> Self {
        Table {
            caption: None,
            header: header.iter().map(|h| h.as_ref().to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn caption(mut self, caption: impl Into<String>) -> Self {
        self.caption = Some(caption.into());
        self
    }

    pub fn row(&mut self, cells: Vec<Cell>) -> &mut Self {
        self.rows.push(cells);
        self
    }

    fn render(&self, out: &mut String) {
        out.push_str("<table>\n");
        if let Some(caption) = &self.caption {
            let _ = writeln!(out, "<caption>{}</caption>", escape(caption));
        }
        out.push_str("<thead><tr>");
        for head in &self.header {
            let _ = write!(out, "<th>{}</th>", escape(head));
        }
        out.push_str("</tr></thead>\n<tbody>\n");
        for row in &self.rows {
            out.push_str("<tr>");
            for cell in row {
                match cell {
                    Cell::Text(text) => {
                        let _ = write!(out, "<td>{}</td>", escape(text));
                    }
                    Cell::Num(value, _) if !value.is_finite() => {
                        out.push_str("<td class=\"num\">—</td>")
                    }
                    Cell::Num(value, decimals) => {
                        let _ =
                            write!(out, "<td class=\"num\">{}</td>", fmt_num(*value, *decimals));
                    }
                }
            }
            out.push_str("</tr>\n");
        }
        out.push_str("</tbody>\n</table>\n");
    }
}

#[derive(Debug, Clone)]
enum Block {
    Section(String),
    Paragraph(String),
    Table(Table),
    Figure { svg: String, caption: String },
    Preformatted(String),
    HowToRead(Vec<String>),
}

/// An HTML report under construction; [`Document::render`] returns the whole file.
#[derive(Debug, Clone)]
pub struct Document {
    title: String,
    blocks: Vec<Block>,
}

impl Document {
    pub fn new(title: impl Into<String>) -> Self {
        Document {
            title: title.into(),
            blocks: Vec::new(),
        }
    }

    /// Starts a new section with a level-2 heading.
    pub fn section(&mut self, heading: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Section(heading.into()));
        self
    }

    /// A paragraph of plain text (escaped; no markup is interpreted).
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    pub fn table(&mut self, table: Table) -> &mut Self {
        self.blocks.push(Block::Table(table));
        self
    }

    /// The chart as inline SVG with a caption below it.
    pub fn figure(&mut self, chart: &Chart, caption: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Figure {
            svg: chart.to_svg(),
            caption: caption.into(),
        });
        self
    }

    /// Monospaced text shown as is (escaped), e.g. a compensation table ready to copy.
    pub fn preformatted(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Preformatted(text.into()));
        self
    }

    /// The highlighted "How to read this" block, one paragraph per entry.
    pub fn how_to_read<S: AsRef<str>>(&mut self, paragraphs: &[S]) -> &mut Self {
        self.blocks.push(Block::HowToRead(
            paragraphs.iter().map(|p| p.as_ref().to_string()).collect(),
        ));
        self
    }

    /// The whole self-contained HTML file.
    pub fn render(&self) -> String {
        let mut out = String::new();
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n",
            title = escape(&self.title),
        );
        for block in &self.blocks {
            match block {
                Block::Section(heading) => {
                    let _ = writeln!(out, "<h2>{}</h2>", escape(heading));
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(out, "<p>{}</p>", escape(text));
                }
                Block::Table(table) => table.render(&mut out),
                Block::Figure { svg, caption } => {
                    let _ = write!(
                        out,
                        "<figure>\n{svg}<figcaption>{}</figcaption>\n</figure>\n",
                        escape(caption)
                    );
                }
                Block::Preformatted(text) => {
                    let _ = writeln!(out, "<pre>{}</pre>", escape(text));
                }
                Block::HowToRead(paragraphs) => {
                    out.push_str("<div class=\"how\">\n<h2>How to read this</h2>\n");
                    for text in paragraphs {
                        let _ = writeln!(out, "<p>{}</p>", escape(text));
                    }
                    out.push_str("</div>\n");
                }
            }
        }
        out.push_str("</body>\n</html>\n");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{Mark, Series};

    fn small_document() -> Document {
        let mut table = Table::new(&["target mm", "x̄↑ µm", "note"]).caption("Per target");
        table.row(vec![Cell::Num(50.0, 1), Cell::Num(9.0, 2), "ok".into()]);
        table.row(vec![
            Cell::Num(100.0, 1),
            Cell::Num(f64::NAN, 2),
            Cell::Text("a < b & c".into()),
        ]);
        let chart = Chart::new("Deviation", "position in mm", "deviation in µm")
            .size(320.0, 200.0)
            .series(Series::new(
                "x̄↑",
                Mark::LineAndPoints,
                vec![(50.0, 9.0), (100.0, 4.0)],
            ));
        let mut doc = Document::new("Report <test>");
        doc.section("Numbers")
            .paragraph("Means are in µm; \"quotes\" & <tags> stay text.")
            .table(table)
            .figure(&chart, "One series.")
            .preformatted("$AA_ENC_COMP[0,0,X1]=0.003\n")
            .how_to_read(&["First paragraph.", "Second <b>paragraph</b>."]);
        doc
    }

    #[test]
    fn small_document_snapshot() {
        insta::assert_snapshot!(small_document().render());
    }

    #[test]
    fn document_is_self_contained() {
        let html = small_document().render();
        for forbidden in [
            "<script",
            "<link",
            "@import",
            "url(http",
            "src=\"http",
            "@font-face",
        ] {
            assert!(!html.contains(forbidden), "found {forbidden}");
        }
        assert!(
            html.contains("<td class=\"num\">—</td>"),
            "NaN cells print a dash"
        );
        assert!(html.contains("Second &lt;b&gt;paragraph&lt;/b&gt;."));
        assert!(html.contains("<title>Report &lt;test&gt;</title>"));
    }
}
