//! What one scene may pull in, in all: a [`Budget`] of triangles, instances, file reads, bytes
//! read and includes, and the [`Account`] a load keeps against it.
//!
//! Each file is bounded on its own (the limits in the parent module); a budget bounds what a
//! scene multiplies: a scene file that lists one model thousands of times, Mitsuba includes
//! that each include the next file several times, a model placed by many shapes. Loaders read
//! through an account ([`Account::read_file`], [`Account::read_text`]) and charge it for what
//! they add ([`Account::charge`]), so that a runaway scene stops with an error naming the
//! budget, what reached it and how to raise it, before it has taken the time and memory.

use super::{read_file_limited, text_from_bytes, MAX_FILE_BYTES, MAX_TEXT_BYTES};
use crate::{Error, Result};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// What a budget counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Resource {
    /// Triangles of the whole scene, over all instances.
    Triangles,
    /// Placed objects (model instances, shapes, glTF nodes with meshes).
    Instances,
    /// Files read (scene files, models, material libraries, textures, buffers, includes).
    FileReads,
    /// Bytes read from all files together.
    BytesRead,
    /// Mitsuba `<include>` elements followed.
    Includes,
}

impl Resource {
    /// Every resource, in the order of [`Budget`]'s fields.
    pub const ALL: [Resource; 5] = [
        Resource::Triangles,
        Resource::Instances,
        Resource::FileReads,
        Resource::BytesRead,
        Resource::Includes,
    ];

    /// The name used by `--budget NAME=N` and in messages.
    pub fn name(self) -> &'static str {
        match self {
            Resource::Triangles => "triangles",
            Resource::Instances => "instances",
            Resource::FileReads => "file-reads",
            Resource::BytesRead => "bytes-read",
            Resource::Includes => "includes",
        }
    }

    /// The resource named `name` (as [`Resource::name`] gives it).
    pub fn from_name(name: &str) -> Option<Resource> {
        Resource::ALL.into_iter().find(|r| r.name() == name)
    }
}

/// The most one scene may pull in, in all. [`Budget::default`] is generous for real scenes
/// (the largest public research scenes have some 10 million triangles and a few thousand
/// files) and stops a runaway one within seconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Triangles over all instances.
    pub triangles: u64,
    /// Placed objects.
    pub instances: u64,
    /// Files read.
    pub file_reads: u64,
    /// Bytes read from all files together.
    pub bytes_read: u64,
    /// Mitsuba `<include>`s followed.
    pub includes: u64,
}

impl Default for Budget {
    fn default() -> Self {
        Budget {
            triangles: 20_000_000,
            instances: 100_000,
            file_reads: 10_000,
            bytes_read: 8 << 30,
            includes: 1_000,
        }
    }
}

impl Budget {
    /// A budget that never stops a load (for tools that trust their input).
    pub const UNLIMITED: Budget = Budget {
        triangles: u64::MAX,
        instances: u64::MAX,
        file_reads: u64::MAX,
        bytes_read: u64::MAX,
        includes: u64::MAX,
    };

    /// The cap on `resource`.
    pub fn get(&self, resource: Resource) -> u64 {
        match resource {
            Resource::Triangles => self.triangles,
            Resource::Instances => self.instances,
            Resource::FileReads => self.file_reads,
            Resource::BytesRead => self.bytes_read,
            Resource::Includes => self.includes,
        }
    }

    /// Sets the cap on `resource`.
    pub fn set(&mut self, resource: Resource, value: u64) {
        match resource {
            Resource::Triangles => self.triangles = value,
            Resource::Instances => self.instances = value,
            Resource::FileReads => self.file_reads = value,
            Resource::BytesRead => self.bytes_read = value,
            Resource::Includes => self.includes = value,
        }
    }

    /// Applies `NAME=N` (as `--budget` takes it): a resource name and a count, which may end in
    /// `k`, `M` or `G` (thousands, millions, billions; for `bytes-read` also `KiB`, `MiB` and
    /// `GiB`).
    pub fn apply(&mut self, text: &str) -> Result<()> {
        let names = || {
            Resource::ALL
                .iter()
                .map(|r| r.name())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (name, value) = text.split_once('=').ok_or_else(|| {
            Error::InvalidArgument(format!(
                "--budget {text}: expected NAME=N, with NAME one of {}",
                names()
            ))
        })?;
        let resource = Resource::from_name(name.trim()).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "--budget {text}: unknown budget '{}'; expected one of {}",
                name.trim(),
                names()
            ))
        })?;
        let value = parse_count(value.trim()).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "--budget {text}: '{}' is not a positive count (e.g. 50M, 2G, 16GiB)",
                value.trim()
            ))
        })?;
        self.set(resource, value);
        Ok(())
    }
}

/// A count with an optional suffix: `k`/`M`/`G` (powers of 1000) or `KiB`/`MiB`/`GiB`.
fn parse_count(text: &str) -> Option<u64> {
    const SUFFIXES: [(&str, u64); 6] = [
        ("KiB", 1 << 10),
        ("MiB", 1 << 20),
        ("GiB", 1 << 30),
        ("k", 1_000),
        ("M", 1_000_000),
        ("G", 1_000_000_000),
    ];
    let (digits, scale) = SUFFIXES
        .iter()
        .find_map(|&(s, scale)| text.strip_suffix(s).map(|d| (d, scale)))
        .unwrap_or((text, 1));
    let value: u64 = digits.trim().replace('_', "").parse().ok()?;
    value.checked_mul(scale).filter(|&v| v > 0)
}

/// A count with thousands separators, for messages.
pub(crate) fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// What one load has pulled in so far, against its [`Budget`]. Shared by the threads of the
/// load (textures are decoded in parallel), hence the atomics.
#[derive(Debug)]
pub struct Account {
    budget: Budget,
    used: [AtomicU64; 5],
    /// The first refused charge: loaders that turn a failed texture into a warning go on, and
    /// the load still fails at [`Account::check`].
    refused: Mutex<Option<String>>,
}

impl Default for Account {
    fn default() -> Self {
        Account::new(Budget::default())
    }
}

impl Account {
    /// An empty account against `budget`.
    pub fn new(budget: Budget) -> Account {
        Account {
            budget,
            used: Default::default(),
            refused: Mutex::new(None),
        }
    }

    /// The first charge this account refused, as an error: a loader that went on after a
    /// refused texture or material library still fails here.
    pub fn check(&self) -> Result<()> {
        match self
            .refused
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
        {
            Some(message) => Err(Error::OverBudget(message.clone())),
            None => Ok(()),
        }
    }

    /// The budget this account is kept against.
    pub fn budget(&self) -> &Budget {
        &self.budget
    }

    /// How much of `resource` the load has used.
    pub fn used(&self, resource: Resource) -> u64 {
        self.used[resource as usize].load(Ordering::Relaxed)
    }

    /// Charges `amount` of `resource` for `what` (a phrase naming who asks, such as
    /// "model 'chair.obj' placed 5000 times"); an error when the total would pass the budget.
    /// A refused charge is not booked.
    pub fn charge(
        &self,
        resource: Resource,
        amount: u64,
        what: impl FnOnce() -> String,
    ) -> Result<()> {
        let cell = &self.used[resource as usize];
        let cap = self.budget.get(resource);
        cell.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |used| {
            used.checked_add(amount).filter(|&total| total <= cap)
        })
        .map(|_| ())
        .map_err(|used| {
            let e = over_budget(resource, cap, used, amount, what());
            let mut refused = self.refused.lock().unwrap_or_else(|e| e.into_inner());
            refused.get_or_insert_with(|| e.to_string());
            e
        })
    }

    /// Reads a binary input file of at most [`MAX_FILE_BYTES`], charging one file read and its
    /// bytes.
    pub fn read_file(&self, path: &Path) -> Result<Vec<u8>> {
        self.read_file_limited(path, MAX_FILE_BYTES)
    }

    /// Reads a UTF-8 text file of at most [`MAX_TEXT_BYTES`], charging one file read and its
    /// bytes.
    pub fn read_text(&self, path: &Path) -> Result<String> {
        let bytes = self.read_file_limited(path, MAX_TEXT_BYTES)?;
        text_from_bytes(path, bytes)
    }

    /// Reads a file of at most `limit` bytes, charging one file read and its size before
    /// reading it.
    pub fn read_file_limited(&self, path: &Path, limit: u64) -> Result<Vec<u8>> {
        let size = super::check_file(path, limit)?;
        let name = || format!("reading {}", path.display());
        self.charge(Resource::FileReads, 1, name)?;
        self.charge(Resource::BytesRead, size, name)?;
        read_file_limited(path, limit)
    }
}

fn over_budget(resource: Resource, cap: u64, used: u64, amount: u64, what: String) -> Error {
    let shown = |n: u64| match resource {
        Resource::BytesRead => super::human(n),
        _ => grouped(n),
    };
    Error::OverBudget(format!(
        "{what}: the scene would pull in {} {}, more than its budget of {} \
         (it had {} already); if the scene is meant to be this large, raise the budget with \
         `--budget {}=N` (octolux::limits::Budget in the library)",
        shown(used.saturating_add(amount)),
        noun(resource),
        shown(cap),
        shown(used),
        resource.name()
    ))
}

fn noun(resource: Resource) -> &'static str {
    match resource {
        Resource::Triangles => "triangles",
        Resource::Instances => "instances",
        Resource::FileReads => "file reads",
        Resource::BytesRead => "bytes read",
        Resource::Includes => "includes",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_take_suffixes() {
        assert_eq!(parse_count("50M"), Some(50_000_000));
        assert_eq!(parse_count("16GiB"), Some(16 << 30));
        assert_eq!(parse_count("1_000"), Some(1000));
        assert_eq!(parse_count("0"), None);
        assert_eq!(parse_count("-3"), None);
        assert_eq!(parse_count("99999999999G"), None, "overflow is refused");
    }

    #[test]
    fn a_budget_is_set_by_name() {
        let mut b = Budget::default();
        b.apply("triangles=50M").unwrap();
        assert_eq!(b.triangles, 50_000_000);
        let e = b.apply("polygons=3").unwrap_err().to_string();
        assert!(
            e.contains("unknown budget 'polygons'") && e.contains("triangles"),
            "{e}"
        );
        let e = b.apply("triangles").unwrap_err().to_string();
        assert!(e.contains("NAME=N"), "{e}");
    }

    #[test]
    fn a_charge_past_the_budget_is_refused_and_named() {
        let account = Account::new(Budget {
            triangles: 100,
            ..Budget::default()
        });
        account
            .charge(Resource::Triangles, 60, || "first".into())
            .unwrap();
        let e = account
            .charge(Resource::Triangles, 50, || {
                "model 'm.obj' placed 5 times".into()
            })
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("model 'm.obj' placed 5 times")
                && e.contains("110 triangles")
                && e.contains("budget of 100")
                && e.contains("--budget triangles=N"),
            "{e}"
        );
        assert_eq!(
            account.used(Resource::Triangles),
            60,
            "a refused charge is not booked"
        );
    }

    #[test]
    fn reads_are_charged() {
        let dir = std::env::temp_dir().join(format!("octolux-budget-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("ten.txt");
        std::fs::write(&file, "0123456789").unwrap();
        let account = Account::new(Budget {
            file_reads: 2,
            ..Budget::default()
        });
        account.read_text(&file).unwrap();
        account.read_file(&file).unwrap();
        assert_eq!(account.used(Resource::BytesRead), 20);
        let e = account.read_file(&file).unwrap_err().to_string();
        assert!(
            e.contains("file reads") && e.contains("--budget file-reads=N"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
