//! The golden hash lists' text, read without allocation: `KEY WORD…` lines that set a run up,
//! and `KIND ROW VALUE` lines that pin a check.

use core::str::SplitAsciiWhitespace;

use sinew_core::driver::Intrinsics;

/// The words after `key` on the first line whose first word it is.
pub(crate) fn words<'t>(text: &'t str, key: &str) -> Option<SplitAsciiWhitespace<'t>> {
    let mut words = text
        .lines()
        .map(str::split_ascii_whitespace)
        .find(|w| w.clone().next() == Some(key))?;
    words.next();
    Some(words)
}

/// The next `N` of `words` as numbers; `None` if there are fewer or one does not parse.
pub(crate) fn numbers<'t, const N: usize>(
    words: &mut impl Iterator<Item = &'t str>,
) -> Option<[f32; N]> {
    let mut out = [0.0f32; N];
    for v in &mut out {
        *v = words.next()?.parse().ok()?;
    }
    Some(out)
}

/// The camera of the `track FILE FX FY CX CY` line.
pub(crate) fn camera(text: &str) -> Option<Intrinsics> {
    let mut t = words(text, "track")?.skip(1);
    let [fx, fy, cx, cy] = numbers(&mut t)?;
    Some(Intrinsics { fx, fy, cx, cy })
}

/// The value of the `KIND ROW VALUE` line of `kind` and `row`.
pub(crate) fn pinned<'t>(text: &'t str, kind: &str, row: usize) -> Option<&'t str> {
    text.lines().find_map(|line| {
        let mut w = line.split_ascii_whitespace();
        if w.next()? != kind || w.next()?.parse::<usize>().ok()? != row {
            return None;
        }
        w.next()
    })
}

/// The pinned hash (hexadecimal) of check `kind` of row `row`.
pub(crate) fn pinned_hash(text: &str, kind: &str, row: usize) -> Option<u64> {
    u64::from_str_radix(pinned(text, kind, row)?, 16).ok()
}

/// A run of `checks` checks a row over `rows` rows, counted by `next`: the row and check it
/// stands at, `next` moved on; `None` past the last row.
pub(crate) fn next_check(next: &mut usize, rows: usize, checks: usize) -> Option<(usize, usize)> {
    let (row, check) = (*next / checks, *next % checks);
    if row >= rows {
        return None;
    }
    *next += 1;
    Some((row, check))
}
