//! CSV tables as text, written with the `csv` crate: a field is quoted only where it must
//! be (a comma, a quote or a line break in it), every other byte is the caller's own
//! formatting, and records end in `\n`.

use std::io;

/// A CSV text of `header` and `rows`, each row's fields in the header's order (rows of
/// another length are written as they are).
///
/// ```
/// use ghm::report::table::csv_text;
///
/// let text = csv_text(["controller", "epi"], [["MPC", "1.5e0"], ["RL-MPC (sac, 6h)", ""]])?;
/// assert_eq!(text, "controller,epi\nMPC,1.5e0\n\"RL-MPC (sac, 6h)\",\n");
/// # Ok::<(), std::io::Error>(())
/// ```
pub fn csv_text<H, R>(header: H, rows: impl IntoIterator<Item = R>) -> io::Result<String>
where
    H: IntoIterator,
    H::Item: AsRef<str>,
    R: IntoIterator,
    R::Item: AsRef<str>,
{
    let mut out = csv_writer(Vec::new());
    out.write_record(header.into_iter().map(|h| h.as_ref().as_bytes().to_vec()))?;
    for row in rows {
        out.write_record(row.into_iter().map(|f| f.as_ref().as_bytes().to_vec()))?;
    }
    let bytes = out.into_inner().map_err(|e| e.into_error())?;
    String::from_utf8(bytes).map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
}

/// A CSV writer over `out` as ghm writes its tables: `,`, quoting only where needed, `\n`
/// after each record, rows of any length.
pub fn csv_writer<W: io::Write>(out: W) -> csv::Writer<W> {
    csv::WriterBuilder::new()
        .flexible(true)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(out)
}
