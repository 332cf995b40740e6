//! This library's read-only data made resident in the process's page tables, once at load.
//!
//! Why: the compiler turns some of the kernels' branch-free code into masked vector loads of
//! constants (the lane loops' finiteness check every 64 steps builds the set of bad lanes as a
//! load of the lanes' bits [1, 2, 4, …] under the mask of non-finite values). When all is well
//! the mask is zero and nothing is read, but the address must still be translated, and a page
//! of the library that nothing else has touched has no translation to find: each such load
//! then takes the processor's slow path. On AMD Zen 5 that made the untracked 8-lane FPU loop
//! 9.0 instead of 6.6 ns a step (1000 lanes: 1.26 instead of 0.95 ns per trajectory-step),
//! depending only on whether other code had touched that page (the planner's measuring did:
//! `TRIGINT_PLAN=estimate` and `TRIGINT_ISA` ran slower). Reading one byte of every page of the
//! library's read-only mappings (2 MB) at load makes every run take the fast path.

/// Reads one byte of every page of the read-only, non-executable mappings of the file that holds
/// this code (Linux: from `/proc/self/maps`); returns the pages read (0 where there is no such
/// file to read, or on other systems).
pub fn map_read_only_data() -> usize {
    #[cfg(target_os = "linux")]
    {
        let here = map_read_only_data as *const () as usize;
        std::fs::read_to_string("/proc/self/maps")
            .map(|maps| touch(&maps, here))
            .unwrap_or(0)
    }
    #[cfg(not(target_os = "linux"))]
    {
        0
    }
}

/// A mapping of `/proc/self/maps`: its addresses, permissions and file.
#[cfg(target_os = "linux")]
struct Mapping<'a> {
    start: usize,
    end: usize,
    perms: &'a str,
    file: &'a str,
}

#[cfg(target_os = "linux")]
fn parse(line: &str) -> Option<Mapping<'_>> {
    let mut fields = line.split_whitespace();
    let (range, perms) = (fields.next()?, fields.next()?);
    let file = fields.nth(3)?; // after the offset, the device and the inode
    let (start, end) = range.split_once('-')?;
    Some(Mapping {
        start: usize::from_str_radix(start, 16).ok()?,
        end: usize::from_str_radix(end, 16).ok()?,
        perms,
        file,
    })
}

/// The read-only, non-executable mappings (start, end) of the file mapped at `here`.
#[cfg(target_os = "linux")]
fn read_only_ranges(maps: &str, here: usize) -> Vec<(usize, usize)> {
    let Some(file) = maps
        .lines()
        .filter_map(parse)
        .find(|m| m.start <= here && here < m.end)
        .map(|m| m.file)
    else {
        return Vec::new();
    };
    maps.lines()
        .filter_map(parse)
        .filter(|m| m.file == file && m.perms.starts_with("r--"))
        .map(|m| (m.start, m.end))
        .collect()
}

#[cfg(target_os = "linux")]
fn touch(maps: &str, here: usize) -> usize {
    const PAGE: usize = 4096;
    let mut pages = 0;
    for (start, end) in read_only_ranges(maps, here) {
        for page in (start..end).step_by(PAGE) {
            // SAFETY: a readable mapping of this library, mapped while the library is.
            unsafe { std::ptr::read_volatile(page as *const u8) };
            pages += 1;
        }
    }
    pages
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn the_read_only_mappings_of_this_file_are_read_and_nothing_else() {
        // The test binary holds this code: its read-only data is read, page by page.
        let pages = map_read_only_data();
        assert!(pages > 0);
        assert_eq!(map_read_only_data(), pages);
        // Made-up maps: of the file holding the address, its read-only data alone.
        let maps = "1000-3000 r--p 00000000 fe:00 7 /lib/a.so\n\
                    3000-5000 r-xp 00002000 fe:00 7 /lib/a.so\n\
                    5000-6000 rw-p 00004000 fe:00 7 /lib/a.so\n\
                    6000-7000 r--p 00005000 fe:00 7 /lib/a.so\n\
                    7000-8000 rw-p 00000000 00:00 0\n\
                    9000-a000 r--p 00000000 fe:00 8 /lib/b.so\n";
        assert_eq!(
            read_only_ranges(maps, 0x4000),
            [(0x1000, 0x3000), (0x6000, 0x7000)]
        );
        assert_eq!(read_only_ranges(maps, 0x9800), [(0x9000, 0xa000)]);
        assert!(read_only_ranges(maps, 0x7800).is_empty()); // anonymous: no file
        assert!(read_only_ranges(maps, 0xb000).is_empty());
        assert!(parse("garbage").is_none());
    }
}
