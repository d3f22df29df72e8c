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
//! - nesting is bounded: dictionaries at most [`MAX_NEST`] deep, time samples hold no time
//!   samples or dictionaries, and value types that none of the fields Kami reads can hold
//!   (references, payloads, relocates) are refused in them, as are arrays and payload list
//!   ops marked inlined (openusd reads them at their offset all the same);
//! - every value checked adds what openusd will decode for it to one running total, so
//!   many time samples or dictionary entries pointing at one large array count each time
//!   they would be decoded; the total is at most [`decode_budget`];
//! - the path table is decoded here (LZ4, then Pixar's integer coding) and walked as
//!   openusd walks it, with every index checked and the bytes of the path strings it would
//!   build added up (a chain of nested paths costs the square of its depth).
//!
//! So a hostile crate file costs at most [`decode_budget`] (64 times its size, and at
//! least 64 MiB) in decoded values and path strings, not a terabyte allocation.

const MAX_NEST: usize = 16;

/// Bytes a crate file may decode to, in the values Kami reads and the path strings:
/// 64 times the file, at least 64 MiB.
pub fn decode_budget(file_len: usize) -> u64 {
    (file_len as u64).saturating_mul(64).max(64 << 20)
}

/// The fields Kami asks `openusd` for on prims and attributes (`usdc::walk`; the crate
/// names `propertyChildren` `properties`), besides the stage's (`usdc::STAGE_KEYS`).
const READ: &[&str] = &[
    "specifier",
    "typeName",
    "active",
    "properties",
    "propertyChildren",
    "primChildren",
    "interpolation",
    "default",
    "timeSamples",
];

struct File<'a> {
    b: &'a [u8],
    /// (major, minor, patch).
    version: (u8, u8, u8),
    /// Bytes decoded so far (values and path strings), against [`decode_budget`].
    decoded: std::cell::Cell<u64>,
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

    /// Count `bytes` more decoded; refused past the budget.
    fn decode(&self, what: &str, bytes: u64) -> Result<(), String> {
        let total = self.decoded.get().saturating_add(bytes);
        self.decoded.set(total);
        let budget = decode_budget(self.b.len());
        if total > budget {
            return Err(format!(
                "{what}: the values would decode to more than {budget} bytes ({} times the file)",
                budget / self.b.len().max(1) as u64
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
        decoded: std::cell::Cell::new(0),
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
    let mut token_lens: Vec<u64> = Vec::new();
    if let Some((at, end)) = section("TOKENS") {
        let count = f.u64_at(at)?;
        let raw = f.u64_at(at + 8)?;
        let size = f.u64_at(at + 16)?;
        if size > f.room(at + 24, end) || raw > size.saturating_mul(255) + 16 || count > raw {
            return Err(format!(
                "TOKENS: {count} tokens in {raw} bytes from a {size}-byte block do not fit its section"
            ));
        }
        let text = f.lz4("TOKENS", at + 24, size, raw)?;
        token_lens = text
            .strip_suffix(&[0])
            .unwrap_or(&text)
            .split(|&c| c == 0)
            .map(|t| t.len() as u64)
            .collect();
        if text.is_empty() {
            token_lens.clear();
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
        let mut parts = Vec::new();
        for part in ["PATHS (indices)", "PATHS (names)", "PATHS (jumps)"] {
            let after = f.coded_ints(part, next, n, end)?;
            parts.push(f.ints(part, next, n)?);
            next = after;
        }
        f.decode("PATHS", paths.saturating_mul(24))?;
        f.walk_paths(paths, &parts[0], &parts[1], &parts[2], &token_lens)?;
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
        if READ.contains(&name.as_str()) || super::STAGE_KEYS.contains(&name.as_str()) {
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
        // openusd decodes only a single value from the rep itself: an array (other than an
        // empty one) and a payload list op (55) it reads at the payload offset even when
        // the rep is marked inlined, so such a rep would skip every check below (a token
        // array so marked took a count of 10^15 from the file's header). No writer inlines
        // them: refused.
        if inlined && ((array && at != 0) || ty == 55) {
            return Err(format!(
                "a value of type {ty} marked inlined, which only a single value can be (it would be read at offset {at})"
            ));
        }
        // Inlined, invalid, or an empty array (Pixar's writer stores one with payload 0).
        if inlined || ty == 0 || (array && at == 0) {
            return Ok(());
        }
        let end = u64::MAX;
        let major_minor = (self.version.0, self.version.1);
        // String, asset-path and path-expression arrays: a u64 count of string indices at
        // the payload, whatever the version (openusd's `read_string_vec`).
        if array && matches!(ty, 10 | 12 | 57) {
            let n = self.u64_at(at)?;
            self.fits(what, at + 8, n, 4, end)?;
            return self.decode(what, n.saturating_mul(24));
        }
        // A double vector is read as a float array (`read_floats`), compressed or not.
        if array || ty == 48 {
            let Some(e) = element(if ty == 48 { 9 } else { ty }) else {
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
            let floats = matches!(ty, 7..=9 | 48 | 56);
            // What openusd allocates for the decoded array.
            self.decode(what, n.saturating_mul(e))?;
            // Compression of ints came with 0.5, of floats with 0.6 (before, raw).
            let coded = (ints && major_minor >= (0, 5)) || (floats && major_minor >= (0, 6));
            if compressed && n >= 4 && coded {
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
            40 | 41 | 50 => {
                let n = self.u64_at(at)?;
                self.fits(what, at + 8, n, 4, end)?;
                self.decode(what, n.saturating_mul(24))
            }
            49 => {
                let n = self.u64_at(at)?;
                self.fits(what, at + 8, n, 16, end)?;
                self.decode(what, n.saturating_mul(16))
            }
            // A dictionary: count, then per entry a string index, a jump and a value rep.
            31 => {
                let n = self.u64_at(at)?;
                self.fits(what, at + 8, n, 20, end)?;
                self.decode(what, n.saturating_mul(64))?;
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
                self.decode(what, n.saturating_mul(16))?;
                for i in 0..n {
                    let rep = self.u64_at(reps + 8 + 8 * i)?;
                    // A sample is a value: not samples again, nor a dictionary.
                    if matches!(rep >> 48 & 0xff, 31 | 46) && rep >> 62 & 1 == 0 {
                        return Err("time samples holding time samples or dictionaries".into());
                    }
                    self.value(what, rep, depth + 1)?;
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
                        self.decode(what, n.saturating_mul(24))?;
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

impl File<'_> {
    /// LZ4 block at `at` (the chunk byte, then the block) of `size` bytes, decoding to at
    /// most `raw` bytes.
    fn lz4(&self, what: &str, at: u64, size: u64, raw: u64) -> Result<Vec<u8>, String> {
        if size == 0 {
            return Ok(Vec::new());
        }
        let start = at as usize;
        let block = self
            .b
            .get(start..start + size as usize)
            .ok_or_else(|| format!("{what}: the compressed block runs past the file"))?;
        if block[0] != 0 {
            return Err(format!("{what}: a compressed block in several chunks"));
        }
        self.decode(what, raw)?;
        let mut out = vec![0u8; raw as usize];
        let n = lz4_flex::block::decompress_into(&block[1..], &mut out)
            .map_err(|e| format!("{what}: the compressed block does not decode ({e})"))?;
        out.truncate(n);
        Ok(out)
    }

    /// `count` integers coded as Pixar's crate codes them (a common value, 2-bit codes,
    /// then 1-, 2- or 4-byte deltas), from the LZ4 block at `at` (its u64 size first).
    fn ints(&self, what: &str, at: u64, count: u64) -> Result<Vec<i64>, String> {
        let size = self.u64_at(at)?;
        let n = count as usize;
        let raw = (4 + n.div_ceil(4) + 4 * n) as u64;
        let data = self.lz4(what, at + 8, size, raw)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        let codes = n.div_ceil(4);
        if data.len() < 4 + codes {
            return Err(format!("{what}: the coded integers are cut short"));
        }
        let common = i32::from_le_bytes([data[0], data[1], data[2], data[3]]) as i64;
        let mut at = 4 + codes;
        let mut prev = 0i64;
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let code = data[4 + i / 4] >> (2 * (i % 4)) & 3;
            let width = [0usize, 1, 2, 4][code as usize];
            let bytes = data
                .get(at..at + width)
                .ok_or_else(|| format!("{what}: the coded integers are cut short"))?;
            let delta = match code {
                0 => common,
                1 => bytes[0] as i8 as i64,
                2 => i16::from_le_bytes([bytes[0], bytes[1]]) as i64,
                _ => i32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as i64,
            };
            at += width;
            prev = prev.wrapping_add(delta);
            out.push(prev as i32 as i64);
        }
        Ok(out)
    }

    /// Walk the path tree as openusd builds it (`build_compressed_paths`), with every
    /// index checked and the bytes of the strings it would build counted.
    fn walk_paths(
        &self,
        paths: u64,
        index: &[i64],
        token: &[i64],
        jump: &[i64],
        token_lens: &[u64],
    ) -> Result<(), String> {
        let n = index.len();
        if n == 0 {
            return Ok(());
        }
        let what = "PATHS";
        let mut len = vec![0u64; paths as usize];
        let mut seen = vec![false; n];
        // (entry, parent path length; None for the root)
        let mut pending: Vec<(usize, Option<u64>)> = vec![(0, None)];
        while let Some((mut i, mut parent)) = pending.pop() {
            loop {
                if i >= n || std::mem::replace(&mut seen[i], true) {
                    return Err(format!(
                        "{what}: entry {i} is out of range or reached twice"
                    ));
                }
                let slot = usize::try_from(index[i])
                    .ok()
                    .filter(|&k| k < len.len())
                    .ok_or_else(|| format!("{what}: path index {} is out of range", index[i]))?;
                let here = match parent {
                    None => 1,
                    Some(p) => {
                        let t = token[i].unsigned_abs() as usize;
                        let tl = token_lens
                            .get(t)
                            .ok_or_else(|| format!("{what}: token {t} is out of range"))?;
                        p + 1 + tl
                    }
                };
                len[slot] = here;
                self.decode(what, here)?;
                let (has_child, has_sibling) = (jump[i] > 0 || jump[i] == -1, jump[i] >= 0);
                if has_child && has_sibling {
                    let s = i.checked_add(jump[i] as usize).filter(|&s| s < n);
                    pending.push((s.ok_or("a sibling jump out of range")?, parent));
                }
                if has_child {
                    parent = Some(here);
                } else if !has_sibling {
                    break;
                }
                i += 1;
            }
        }
        Ok(())
    }
}
