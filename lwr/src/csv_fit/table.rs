//! The numeric CSV tables the fit tool reads, through the `csv` crate, with
//! every problem turned into a [`FitError`] naming the file, line, data row
//! and column.

use std::fs;
use std::path::{Path, PathBuf};

use super::FitError;

/// Rows between two reports of [`Table::read_with`]'s progress.
pub const PROGRESS_ROWS: usize = 100_000;

/// A numeric table read from a CSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The file it came from.
    pub file: PathBuf,
    /// Column names, from the header.
    pub names: Vec<String>,
    /// Rows of finite numbers, each as long as `names`.
    pub rows: Vec<Vec<f64>>,
    /// Line in the file of the header.
    pub header_line: usize,
    /// Line in the file of each row.
    pub lines: Vec<usize>,
}

/// Where each line of a text starts, to turn the `csv` crate's byte
/// positions into line numbers in logarithmic time (built once, in one
/// pass: the reader is linear in the file's size).
struct Lines<'a> {
    bytes: &'a [u8],
    /// Byte offset of every line break, in order: each `\n`, and each
    /// lone `\r` (lines end as the `csv` crate's records do: at `\n`,
    /// `\r\n` or a lone `\r`).
    breaks: Vec<usize>,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        let bytes = text.as_bytes();
        let breaks = bytes
            .iter()
            .enumerate()
            .filter_map(|(i, &b)| {
                let lone_cr = b == b'\r' && bytes.get(i + 1) != Some(&b'\n');
                (b == b'\n' || lone_cr).then_some(i)
            })
            .collect();
        Self { bytes, breaks }
    }

    /// The line (from 1) of the first character at or after byte `byte`
    /// that is not a line break: where a record that the `csv` crate says
    /// starts at `byte` really starts (its positions can point at the end
    /// of the previous line, or at blank lines it skipped).
    fn at(&self, byte: u64) -> usize {
        let bytes = self.bytes;
        let mut at = usize::try_from(byte).unwrap_or(bytes.len()).min(bytes.len());
        while at < bytes.len() && (bytes[at] == b'\n' || bytes[at] == b'\r') {
            at += 1;
        }
        1 + self.breaks.partition_point(|&b| b < at)
    }

    /// The line of a record (from 1), or `fallback` if the reader gives none.
    fn of(&self, record: &csv::StringRecord, fallback: usize) -> usize {
        record.position().map_or(fallback, |p| self.at(p.byte()))
    }
}

/// A `csv` crate error as a [`FitError`]: a row of the wrong length as
/// [`FitError::Ragged`] (with the data row and the missing or extra column),
/// anything else as [`FitError::Csv`] with its line.
fn csv_error(
    e: csv::Error,
    lines: &Lines,
    file: &Path,
    names: &[String],
    row: usize,
    fallback_line: usize,
) -> FitError {
    let line = e.position().map_or(fallback_line, |p| lines.at(p.byte()));
    match e.kind() {
        csv::ErrorKind::UnequalLengths { len, .. } => {
            ragged(file, line, row, names, usize::try_from(*len).unwrap_or(usize::MAX))
        }
        _ => FitError::Csv {
            file: file.to_path_buf(),
            line,
            reason: e.to_string(),
        },
    }
}

/// [`FitError::Ragged`] for data row `row` at `line` with `actual` cells.
fn ragged(file: &Path, line: usize, row: usize, names: &[String], actual: usize) -> FitError {
    let detail = if actual < names.len() {
        format!("column {} '{}' is missing", actual + 1, names[actual])
    } else {
        format!("column {} is extra", names.len() + 1)
    };
    FitError::Ragged {
        file: file.to_path_buf(),
        line,
        row,
        expected: names.len(),
        actual,
        detail,
    }
}

impl Table {
    /// Reads a CSV file: a header row of distinct, nonempty column names,
    /// then at least one row of as many finite numbers, comma-separated
    /// (fields may be quoted). Blank lines are skipped; cells are trimmed.
    ///
    /// # Errors
    /// [`FitError::Io`] if the file cannot be read (or is not UTF-8), and
    /// the errors of [`parse`](Self::parse).
    pub fn read(path: &Path) -> Result<Self, FitError> {
        Self::read_with(path, &mut |_| {})
    }

    /// [`read`](Self::read), telling `progress` the rows read so far every
    /// [`PROGRESS_ROWS`] rows. Reading is linear in the file's size.
    ///
    /// # Errors
    /// As [`read`](Self::read).
    pub fn read_with(path: &Path, progress: &mut dyn FnMut(usize)) -> Result<Self, FitError> {
        let text = fs::read_to_string(path).map_err(|source| FitError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Self::parse_with(&text, path, progress)
    }

    /// Parses CSV text as [`read`](Self::read) does; `file` names it in errors.
    ///
    /// # Errors
    /// [`FitError::Empty`], [`FitError::BadHeader`], [`FitError::Ragged`],
    /// [`FitError::BadCell`], [`FitError::NoRows`] or [`FitError::Csv`],
    /// each naming the line (and data row and column where there is one).
    pub fn parse(text: &str, file: &Path) -> Result<Self, FitError> {
        Self::parse_with(text, file, &mut |_| {})
    }

    /// [`parse`](Self::parse) with the progress of [`read_with`](Self::read_with).
    ///
    /// # Errors
    /// As [`parse`](Self::parse).
    pub fn parse_with(text: &str, file: &Path, progress: &mut dyn FnMut(usize)) -> Result<Self, FitError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let lines = Lines::new(text);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            // rows of the wrong length are reported with their row and column
            // below; blank (whitespace-only) lines are one-cell records to skip
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let mut records = reader.records();
        let is_blank = |r: &csv::StringRecord| r.len() == 1 && r[0].is_empty();
        // the header: the first record that is not blank
        let mut last_line = 1;
        let header = loop {
            match records.next() {
                None => {
                    return Err(FitError::Empty {
                        file: file.to_path_buf(),
                    });
                }
                Some(Err(e)) => return Err(csv_error(e, &lines, file, &[], 0, last_line)),
                Some(Ok(r)) if is_blank(&r) => last_line = lines.of(&r, last_line),
                Some(Ok(r)) => break r,
            }
        };
        let header_line = lines.of(&header, last_line);
        let names: Vec<String> = header.iter().map(str::to_owned).collect();
        for (j, name) in names.iter().enumerate() {
            let reason = if name.is_empty() {
                Some("empty column name".to_owned())
            } else if let Some(first) = names[..j].iter().position(|n| n == name) {
                Some(format!("column name '{name}' repeats column {}", first + 1))
            } else if name.parse::<f64>().is_ok() {
                Some(format!(
                    "'{name}' is a number: the first line must be a header of column names"
                ))
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(FitError::BadHeader {
                    file: file.to_path_buf(),
                    line: header_line,
                    column: j + 1,
                    reason,
                });
            }
        }
        let mut rows = Vec::new();
        let mut row_lines = Vec::new();
        let mut line = header_line;
        for record in records {
            let row = rows.len() + 1;
            let record = record.map_err(|e| csv_error(e, &lines, file, &names, row, line + 1))?;
            line = lines.of(&record, line + 1);
            if is_blank(&record) {
                continue;
            }
            if record.len() != names.len() {
                return Err(ragged(file, line, row, &names, record.len()));
            }
            let mut values = Vec::with_capacity(record.len());
            for (j, cell) in record.iter().enumerate() {
                let reason = match cell.parse::<f64>() {
                    _ if cell.is_empty() => Some("empty cell".to_owned()),
                    Ok(v) if v.is_finite() => {
                        values.push(v);
                        None
                    }
                    Ok(_) => Some(format!("'{}' is not a finite number", store::shorten(cell))),
                    Err(_) => Some(format!("cannot read '{}' as a number", store::shorten(cell))),
                };
                if let Some(reason) = reason {
                    return Err(FitError::BadCell {
                        file: file.to_path_buf(),
                        line,
                        row,
                        column: j + 1,
                        name: store::shorten(&names[j]).into_owned(),
                        reason,
                    });
                }
            }
            rows.push(values);
            row_lines.push(line);
            if rows.len() % PROGRESS_ROWS == 0 {
                progress(rows.len());
            }
        }
        if rows.is_empty() {
            return Err(FitError::NoRows {
                file: file.to_path_buf(),
                line: header_line,
            });
        }
        Ok(Self {
            file: file.to_path_buf(),
            names,
            rows,
            header_line,
            lines: row_lines,
        })
    }

    /// Index of the column `name`, or a [`FitError::MissingColumn`].
    pub(super) fn column(&self, name: &str, role: &'static str) -> Result<usize, FitError> {
        self.names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| FitError::MissingColumn {
                file: self.file.clone(),
                line: self.header_line,
                name: name.to_owned(),
                role,
                available: self.names.join(", "),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Table, FitError> {
        Table::parse(text, Path::new("t.csv"))
    }

    #[test]
    fn parses_plain_csv() {
        let t = parse("a, b\r\n1,2\n\n 3 ,4e-1\n").expect("valid");
        assert_eq!(t.names, ["a", "b"]);
        assert_eq!(t.rows, [vec![1.0, 2.0], vec![3.0, 0.4]]);
        assert_eq!(t.lines, [2, 4]);
        assert_eq!(t.header_line, 1);
    }

    #[test]
    fn skips_blank_lines_and_a_byte_order_mark_and_reads_quotes() {
        let t = parse("\u{feff}\n  \n\"a\",b\n \n\"1\",2\n").expect("valid");
        assert_eq!(t.names, ["a", "b"]);
        assert_eq!(t.header_line, 3);
        assert_eq!(t.rows, [vec![1.0, 2.0]]);
        assert_eq!(t.lines, [5]);
    }

    /// Found by the fuzz target (`tests/tests/fuzz_parsers.rs`): a lone
    /// carriage return ends a record, so it ends a line too; every row of
    /// such a file was said to be on line 1.
    #[test]
    fn a_lone_carriage_return_ends_a_line() {
        let t = parse("a\r1\r2\r\n3\n").expect("valid");
        assert_eq!((t.header_line, t.lines.as_slice()), (1, [2, 3, 4].as_slice()));
        let e = parse("a,b\r1,2\r3,x\r").expect_err("bad cell").to_string();
        assert!(e.contains("line 3 (data row 2)"), "{e}");
    }

    #[test]
    fn names_line_row_and_column() {
        let e = parse("a,b\n1,2\n3,x\n").expect_err("bad cell").to_string();
        assert!(e.contains("line 3 (data row 2), column 2 'b'"), "{e}");
        let e = parse("a,b\n1,inf\n").expect_err("inf").to_string();
        assert!(e.contains("column 2 'b'") && e.contains("not a finite"), "{e}");
        let e = parse("a,b\n1\n").expect_err("short").to_string();
        assert!(
            e.contains("line 2 (data row 1)") && e.contains("column 2 'b' is missing"),
            "{e}"
        );
        let e = parse("a,b\n1,2\n\n3,4,5\n").expect_err("long").to_string();
        assert!(
            e.contains("line 4 (data row 2) has 3 cells") && e.contains("column 3 is extra"),
            "{e}"
        );
        assert!(matches!(parse(" \n"), Err(FitError::Empty { .. })));
        assert!(matches!(parse("a,b\n"), Err(FitError::NoRows { line: 1, .. })));
        assert!(matches!(
            parse("a,a\n1,2\n"),
            Err(FitError::BadHeader { column: 2, .. })
        ));
        assert!(matches!(
            parse("1,2\n1,2\n"),
            Err(FitError::BadHeader { column: 1, .. })
        ));
        assert!(matches!(parse("a,\n1,2\n"), Err(FitError::BadHeader { column: 2, .. })));
    }

    #[test]
    fn csv_crate_errors_keep_the_row_and_column() {
        // the reader's own unequal-lengths error becomes the same message as
        // the row check's
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .from_reader("a,b\n1,2\n3\n".as_bytes());
        let e = reader.records().find_map(Result::err).expect("unequal lengths");
        let names = ["a".to_owned(), "b".to_owned()];
        let msg = csv_error(e, &Lines::new("a,b\n1,2\n3\n"), Path::new("t.csv"), &names, 2, 0).to_string();
        assert!(
            msg.contains("t.csv: line 3 (data row 2) has 1 cells") && msg.contains("column 2 'b' is missing"),
            "{msg}"
        );
    }

    /// A large table reads in linear time with progress every
    /// [`PROGRESS_ROWS`] rows, and its lines stay exact (the reader once
    /// rescanned the text from the start for every record).
    #[test]
    fn large_tables_report_progress_and_keep_their_lines() {
        let n = 2 * PROGRESS_ROWS + 17;
        let mut text = String::from("a,b\n");
        for i in 0..n {
            text.push_str(&format!("{i},{}\n", 2 * i));
            if i % 1000 == 0 {
                text.push('\n');
            }
        }
        let mut seen = Vec::new();
        let t = Table::parse_with(&text, Path::new("big.csv"), &mut |r| seen.push(r)).expect("valid");
        assert_eq!(seen, [PROGRESS_ROWS, 2 * PROGRESS_ROWS]);
        assert_eq!(t.rows.len(), n);
        // row i sits on line 2 + i plus the blank lines written before it
        for i in [0, 1, 999, 1000, 1001, n - 1] {
            assert_eq!(t.lines[i], 2 + i + i.div_ceil(1000), "row {i}");
            assert_eq!(t.rows[i], [i as f64, 2.0 * i as f64]);
        }
        let mut bad = text.clone();
        bad.push_str("1,x\n");
        let e = parse(&bad).expect_err("bad cell").to_string();
        let line = 2 + n + n.div_ceil(1000);
        assert!(e.contains(&format!("line {line} (data row {})", n + 1)), "{e}");
    }
}
