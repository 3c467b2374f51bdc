//! The byte encodings the `.pvs` writer (`pvs_file`) lays out (`docs/pvs-format.md`): a set
//! as delta varints or a bitset, whichever is smaller, and the version-2 object section.

use sightline_core::TriangleSet;
use sightline_runtime::format::{ENCODING_BITSET, ENCODING_DELTA_VARINT, NO_INDEX};

use crate::pvs_objects::ObjectTable;

/// The version-2 object section: names length, run count, records, runs, names, CRC-32.
pub(crate) fn object_section(table: &ObjectTable) -> Vec<u8> {
    let runs = table.runs();
    let mut names = Vec::new();
    let mut records = Vec::with_capacity(table.objects.len() * 40);
    for o in &table.objects {
        records.extend_from_slice(&(names.len() as u32).to_le_bytes());
        records.extend_from_slice(&(o.name.len() as u32).to_le_bytes());
        names.extend_from_slice(o.name.as_bytes());
        records.extend_from_slice(&o.index.unwrap_or(NO_INDEX).to_le_bytes());
        records.extend_from_slice(&o.part.unwrap_or(NO_INDEX).to_le_bytes());
        for f in o
            .bounds_min
            .to_array()
            .into_iter()
            .chain(o.bounds_max.to_array())
        {
            records.extend_from_slice(&f.to_le_bytes());
        }
    }
    let mut section = Vec::with_capacity(8 + records.len() + runs.len() * 8 + names.len() + 4);
    section.extend_from_slice(&(names.len() as u32).to_le_bytes());
    section.extend_from_slice(&(runs.len() as u32).to_le_bytes());
    section.extend_from_slice(&records);
    for (object, count) in runs {
        section.extend_from_slice(&object.to_le_bytes());
        section.extend_from_slice(&count.to_le_bytes());
    }
    section.extend_from_slice(&names);
    let crc = crc32fast::hash(&section);
    section.extend_from_slice(&crc.to_le_bytes());
    section
}

/// Encodes a set both ways and keeps the smaller (ties go to the bitset, faster to decode).
pub(crate) fn encode_set(set: &TriangleSet, n: usize) -> (u8, Vec<u8>) {
    let mut varints = Vec::new();
    let mut previous = 0usize;
    for (k, id) in set.ones().enumerate() {
        let gap = if k == 0 { id } else { id - previous };
        previous = id;
        let mut g = gap as u64;
        loop {
            let byte = (g & 0x7f) as u8;
            g >>= 7;
            if g == 0 {
                varints.push(byte);
                break;
            }
            varints.push(byte | 0x80);
        }
    }
    let bitset_len = n.div_ceil(8);
    if varints.len() < bitset_len {
        return (ENCODING_DELTA_VARINT, varints);
    }
    let mut bits = vec![0u8; bitset_len];
    for id in set.ones() {
        bits[id / 8] |= 1 << (id % 8);
    }
    (ENCODING_BITSET, bits)
}
