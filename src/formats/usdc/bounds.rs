//! Sizes checked before `openusd` reads a crate file. Its reader allocates every count it
//! reads from the file (`vec![T::default(); count]`) before reading what is counted, so a
//! damaged count is a terabyte allocation and an abort, not an error (found by
//! `tests/it/fuzz.rs`). Here every count that `CrateFile::open` reads (the table of
//! contents and the six structural sections) and every count inside the values of the
//! fields Kami reads ([`READ`]) is checked against the bytes that hold it:
//!
//! - a plain array of `n` elements of `e` bytes must fit after its count (`n * e` bytes);
//! - an LZ4-compressed block of `c` bytes decodes to at most 255 c (LZ4's ratio limit), and
//!   a count of integers coded into it to at most 4 per decoded byte (2 bits each at the
//!   least), so such a count is at most about 1020 c; the block must be one chunk (the
//!   only kind `openusd` 0.6 decodes);
//! - nesting (dictionaries, time samples) is at most [`MAX_NEST`] deep, and value types
//!   that none of the fields Kami reads can hold (references, payloads, relocates) are
//!   refused in them.
//!
//! So a hostile crate file costs at most about a thousand times its size, as much as a
//! real one of that size could decode to.

const MAX_NEST: usize = 16;

/// The fields Kami asks `openusd` for (`usdc::walk`); the crate names `propertyChildren`
/// `properties`.
const READ: &[&str] = &[
    "specifier",
    "typeName",
    "active",
    "properties",
    "primChildren",
    "interpolation",
    "default",
    "timeSamples",
    "metersPerUnit",
    "upAxis",
    "timeCodesPerSecond",
    "framesPerSecond",
    "startTimeCode",
    "endTimeCode",
];

struct File<'a> {
    b: &'a [u8],
    /// (major, minor, patch).
    version: (u8, u8, u8),
}

impl File<'_> {
    fn u64_at(&self, at: u64) -> Result<u64, String> {
        let a = usize::try_from(at).map_err(|_| format!("offset {at} is past the file"))?;
        self.b
            .get(a..a.saturating_add(8))
            .filter(|s| s.len() == 8)
            .map(|s| u64::from_le_bytes(s.try_into().unwrap_or([0; 8])))
            .ok_or_else(|| format!("offset {at} is past the file's {} bytes", self.b.len()))
    }

    fn u32_at(&self, at: u64) -> Result<u64, String> {
        let a = usize::try_from(at).map_err(|_| format!("offset {at} is past the file"))?;
        self.b
            .get(a..a.saturating_add(4))
            .filter(|s| s.len() == 4)
            .map(|s| u32::from_le_bytes(s.try_into().unwrap_or([0; 4])) as u64)
            .ok_or_else(|| format!("offset {at} is past the file's {} bytes", self.b.len()))
    }

    fn u8_at(&self, at: u64) -> Result<u8, String> {
        usize::try_from(at)
            .ok()
            .and_then(|a| self.b.get(a).copied())
            .ok_or_else(|| format!("offset {at} is past the file's {} bytes", self.b.len()))
    }

    /// Bytes from `at` to `end` (the section's or the file's end).
    fn room(&self, at: u64, end: u64) -> u64 {
        end.min(self.b.len() as u64).saturating_sub(at)
    }

    /// `n` elements of `e` bytes from `at` fit before `end`.
    fn fits(&self, what: &str, at: u64, n: u64, e: u64, end: u64) -> Result<(), String> {
        let room = self.room(at, end);
        if n.checked_mul(e).is_none_or(|need| need > room) {
            return Err(format!(
                "{what} claims {n} elements of {e} bytes at offset {at}, but only {room} bytes follow"
            ));
        }
        Ok(())
    }

    /// An LZ4 block (its u64 size, then the chunk count byte and the data) at `at` holding
    /// `count` coded integers; returns the offset after it.
    fn coded_ints(&self, what: &str, at: u64, count: u64, end: u64) -> Result<u64, String> {
        let size = self.u64_at(at)?;
        let room = self.room(at + 8, end);
        if size > room {
            return Err(format!(
                "{what}: a compressed block of {size} bytes at offset {at}, but only {room} bytes follow"
            ));
        }
        if count > 0 && size == 0 {
            return Err(format!(
                "{what}: {count} values in an empty compressed block"
            ));
        }
        if size > 0 && self.u8_at(at + 8)? != 0 {
            return Err(format!(
                "{what}: a compressed block in several chunks (not read by this crate reader)"
            ));
        }
        if count > size.saturating_mul(1020) + 4 {
            return Err(format!(
                "{what}: {count} values cannot come out of a {size}-byte compressed block"
            ));
        }
        Ok(at + 8 + size)
    }
}

/// Check the file's structure and the values of the fields Kami reads.
pub fn check(b: &[u8]) -> Result<(), String> {
    if b.len() < 32 {
        return Err(format!(
            "the crate file is {} bytes, shorter than its 32-byte header",
            b.len()
        ));
    }
    let f = File {
        b,
        version: (b[8], b[9], b[10]),
    };
    let (major, minor, patch) = f.version;
    if major != 0 || !(4..=12).contains(&minor) {
        return Err(format!(
            "crate version {major}.{minor}.{patch}: Kami reads versions 0.4.0 to 0.12 (USD since 2017)"
        ));
    }
    let toc = f.u64_at(16)?;
    let count = f.u64_at(toc)?;
    if count == 0 || count >= 64 {
        return Err(format!("the table of contents lists {count} sections"));
    }
    f.fits("the table of contents", toc + 8, count, 32, u64::MAX)?;
    let mut sections = Vec::new();
    for i in 0..count {
        let at = toc + 8 + 32 * i;
        let raw = &b[at as usize..at as usize + 16];
        let name: String = raw
            .iter()
            .take_while(|&&c| c != 0)
            .map(|&c| c as char)
            .collect();
        let start = f.u64_at(at + 16)?;
        let size = f.u64_at(at + 24)?;
        if start.checked_add(size).is_none_or(|e| e > b.len() as u64) {
            return Err(format!(
                "section {name:?} runs from {start} for {size} bytes, past the file's {} bytes",
                b.len()
            ));
        }
        sections.push((name, start, start + size));
    }
    let section = |n: &str| sections.iter().find(|s| s.0 == n).map(|s| (s.1, s.2));
    if let Some((at, end)) = section("TOKENS") {
        let count = f.u64_at(at)?;
        let raw = f.u64_at(at + 8)?;
        let size = f.u64_at(at + 16)?;
        if size > f.room(at + 24, end) || raw > size.saturating_mul(255) + 16 || count > raw {
            return Err(format!(
                "TOKENS: {count} tokens in {raw} bytes from a {size}-byte block do not fit its section"
            ));
        }
    }
    if let Some((at, end)) = section("STRINGS") {
        let n = f.u64_at(at)?;
        f.fits("STRINGS", at + 8, n, 4, end)?;
    }
    if let Some((at, end)) = section("FIELDS") {
        let fields = f.u64_at(at)?;
        let next = f.coded_ints("FIELDS (names)", at + 8, fields, end)?;
        // The value reps decode to `fields` u64s, bounded with the names above.
        f.coded_ints("FIELDS (values)", next, 0, end)?;
    }
    if let Some((at, end)) = section("FIELDSETS") {
        let n = f.u64_at(at)?;
        f.coded_ints("FIELDSETS", at + 8, n, end)?;
    }
    if let Some((at, end)) = section("PATHS") {
        let paths = f.u64_at(at)?;
        let n = f.u64_at(at + 8)?;
        if paths > (end - at).saturating_mul(1020) {
            return Err(format!("PATHS claims {paths} paths in {} bytes", end - at));
        }
        let mut next = at + 16;
        for part in ["PATHS (indices)", "PATHS (names)", "PATHS (jumps)"] {
            next = f.coded_ints(part, next, n, end)?;
        }
    }
    if let Some((at, end)) = section("SPECS") {
        let n = f.u64_at(at)?;
        let mut next = at + 8;
        for part in ["SPECS (paths)", "SPECS (field sets)", "SPECS (types)"] {
            next = f.coded_ints(part, next, n, end)?;
        }
    }
    // The structure holds: let openusd read it, then check the values Kami will ask for.
    let file = openusd::usdc::CrateFile::open(std::io::Cursor::new(b))
        .map_err(|e| format!("the crate file cannot be read: {e:#}"))?;
    for field in &file.fields {
        let Some(name) = file.tokens.get(field.token_index) else {
            continue;
        };
        if READ.contains(&name.as_str()) {
            f.value(name, field.value_rep.0, 0)
                .map_err(|m| format!("the field {name:?}: {m}"))?;
        }
    }
    Ok(())
}

/// Element sizes of array value types (the crate's `Type` numbers).
fn element(ty: u64) -> Option<u64> {
    Some(match ty {
        1 | 2 => 1,              // bool, uchar
        3 | 4 | 8 => 4,          // int, uint, float
        5 | 6 | 9 | 56 => 8,     // int64, uint64, double, timecode
        7 => 2,                  // half
        10..=12 | 57 => 4,       // string, token, asset path, path expression (indices)
        13 => 32,                // matrix2d
        14 => 72,                // matrix3d
        15 => 128,               // matrix4d
        16 | 27 => 32,           // quatd, vec4d
        17 | 28 | 19 | 30 => 16, // quatf, vec4f, vec2d, vec4i
        18 | 29 | 20 | 22 => 8,  // quath, vec4h, vec2f, vec2i
        21 => 4,                 // vec2h
        23 => 24,                // vec3d
        24 | 26 => 12,           // vec3f, vec3i
        25 => 6,                 // vec3h
        _ => return None,
    })
}

impl File<'_> {
    /// A value representation (`ValueRep`) and what it points to.
    fn value(&self, what: &str, rep: u64, depth: usize) -> Result<(), String> {
        if depth > MAX_NEST {
            return Err(format!("values nest deeper than {MAX_NEST} levels"));
        }
        let array = rep >> 63 & 1 == 1;
        let inlined = rep >> 62 & 1 == 1;
        let compressed = rep >> 61 & 1 == 1;
        let ty = rep >> 48 & 0xff;
        let at = rep & ((1 << 48) - 1);
        if inlined || ty == 0 {
            return Ok(());
        }
        let end = u64::MAX;
        let major_minor = (self.version.0, self.version.1);
        if array {
            let Some(e) = element(ty) else {
                return Err(format!(
                    "an array of value type {ty}, which holds no numbers"
                ));
            };
            let mut p = at;
            if major_minor < (0, 5) {
                p += 4;
            }
            let (n, len) = if major_minor < (0, 7) {
                (self.u32_at(p)?, 4)
            } else {
                (self.u64_at(p)?, 8)
            };
            p += len;
            let ints = matches!(ty, 3..=6);
            let floats = matches!(ty, 7..=9 | 56);
            if compressed && n >= 4 && (ints || floats) {
                if ints {
                    self.coded_ints(what, p, n, end)?;
                } else {
                    match self.u8_at(p)? {
                        b'i' => {
                            self.coded_ints(what, p + 1, n, end)?;
                        }
                        b't' => {
                            let lut = self.u32_at(p + 1)?;
                            self.fits(what, p + 5, lut, e, end)?;
                            self.coded_ints(what, p + 5 + lut * e, n, end)?;
                        }
                        c => return Err(format!("a compressed array of unknown code {c}")),
                    }
                }
                return Ok(());
            }
            return self.fits(what, p, n, e, end);
        }
        match ty {
            // Token, string and path vectors (indices), doubles, layer offsets.
            40 | 41 | 50 => self.fits(what, at + 8, self.u64_at(at)?, 4, end),
            48 => self.fits(what, at + 8, self.u64_at(at)?, 8, end),
            49 => self.fits(what, at + 8, self.u64_at(at)?, 16, end),
            // A dictionary: count, then per entry a string index, a jump and a value rep.
            31 => {
                let n = self.u64_at(at)?;
                self.fits(what, at + 8, n, 20, end)?;
                let mut p = at + 8;
                for _ in 0..n {
                    let jump = self.u64_at(p + 4)? as i64;
                    let r = (p + 4).checked_add_signed(jump).ok_or("a jump out of the file")?;
                    self.value(what, self.u64_at(r)?, depth + 1)?;
                    // openusd reads on from after the rep (r + 8).
                    p = r + 8;
                }
                Ok(())
            }
            // Time samples: a jump to the times' rep, then the count and the value reps.
            46 => {
                let jump = self.u64_at(at)? as i64;
                let times_at = at.checked_add_signed(jump).ok_or("a jump out of the file")?;
                let times = self.u64_at(times_at)?;
                self.value(what, times, depth + 1)?;
                let jump = self.u64_at(times_at + 8)? as i64;
                let reps = (times_at + 8)
                    .checked_add_signed(jump)
                    .ok_or("a jump out of the file")?;
                let n = self.u64_at(reps)?;
                self.fits(what, reps + 8, n, 8, end)?;
                for i in 0..n {
                    self.value(what, self.u64_at(reps + 8 + 8 * i)?, depth + 1)?;
                }
                Ok(())
            }
            // List ops of tokens, strings, paths and integers: a header, then per list a
            // count and its items.
            32..=34 | 36..=39 | 54 => {
                let header = self.u8_at(at)?;
                let e = if matches!(ty, 37 | 39) { 8 } else { 4 };
                let mut p = at + 1;
                // openusd's order: explicit, added, prepended, appended, deleted, ordered.
                for bit in [1u8 << 1, 1 << 2, 1 << 5, 1 << 6, 1 << 3, 1 << 4] {
                    if header & bit != 0 {
                        let n = self.u64_at(p)?;
                        self.fits(what, p + 8, n, e, end)?;
                        p += 8 + n * e;
                    }
                }
                Ok(())
            }
            // Scalars stored out of line (fixed size, read in place), specifiers, blocks.
            1..=30 | 42..=44 | 51 | 52 | 56 | 57 => Ok(()),
            other => Err(format!(
                "a value of type {other} (a reference, payload or relocation) where Kami expects a value"
            )),
        }
    }
}
