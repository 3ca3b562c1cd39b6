//! The framing both sectioned layouts (`FWF2`, `FWP2`) share: after a fixed header, a
//! section count (u8) and that many sections of kind (u8), length (u32) and body. A
//! decoder skips the kinds it does not know and the end of a body past the fields it
//! knows: that is how a layout grows without breaking its readers (PROTOCOL.md, "Versions
//! and growth").

use crate::{DecodeError, Reader, Writer};

/// Writes the count and the sections after a header.
pub(crate) struct SectionsOut {
    count_at: usize,
    count: u8,
}

impl SectionsOut {
    /// Starts the sections at the end of `out` (writes the count, filled in by
    /// [`SectionsOut::finish`]).
    pub(crate) fn start(out: &mut Vec<u8>) -> SectionsOut {
        out.put_u8(0);
        SectionsOut {
            count_at: out.len() - 1,
            count: 0,
        }
    }

    /// Opens a section of `kind`: its body is what is written to `out` until
    /// [`SectionsOut::close`] with the returned slot.
    pub(crate) fn open(&mut self, out: &mut Vec<u8>, kind: u8) -> usize {
        self.count += 1;
        out.put_u8(kind);
        out.slot_u32()
    }

    pub(crate) fn close(out: &mut Vec<u8>, slot: usize) {
        let length = out.len() - slot - 4;
        out.fill_u32(slot, length as u32);
    }

    pub(crate) fn finish(self, out: &mut [u8]) {
        out[self.count_at] = self.count;
    }
}

/// One section as read: its kind, where it starts in the message, and a reader over its
/// body.
pub(crate) struct Section<'a> {
    pub(crate) kind: u8,
    pub(crate) at: usize,
    pub(crate) body: Reader<'a>,
}

/// Reads the section count and every section to the end of the message, refusing a
/// section that runs past it and bytes after the last one.
pub(crate) fn read_sections<'a>(r: &mut Reader<'a>) -> Result<Vec<Section<'a>>, DecodeError> {
    let count = r.u8("section count")?;
    let mut sections = Vec::with_capacity(usize::from(count));
    for _ in 0..count {
        let at = r.position();
        let kind = r.u8("section")?;
        let length = r.u32("section")? as usize;
        let base = r.position();
        let body = r.take(length, "section").map_err(|_| DecodeError::Invalid {
            field: "section",
            at,
            problem: format!(
                "section of kind {kind} claims {length} bytes, {} are left",
                r.remaining()
            ),
        })?;
        sections.push(Section {
            kind,
            at,
            body: Reader::within(body, base),
        });
    }
    r.finish()?;
    Ok(sections)
}

/// Which kinds a message has given, to refuse one given twice.
pub(crate) struct KindsSeen([bool; 256]);

impl KindsSeen {
    pub(crate) fn new() -> KindsSeen {
        KindsSeen([false; 256])
    }

    /// Marks the kind of the section at byte `at`, refusing it when seen before.
    pub(crate) fn mark(&mut self, kind: u8, at: usize, name: &'static str) -> Result<(), DecodeError> {
        if std::mem::replace(&mut self.0[usize::from(kind)], true) {
            return Err(DecodeError::Invalid {
                field: name,
                at,
                problem: format!("section {name} (kind {kind}) given twice"),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_frame_their_bodies_and_refuse_overruns() {
        let mut out = b"HEAD".to_vec();
        let mut sections = SectionsOut::start(&mut out);
        let slot = sections.open(&mut out, 7);
        out.extend_from_slice(&[1, 2, 3]);
        SectionsOut::close(&mut out, slot);
        let slot = sections.open(&mut out, 200);
        SectionsOut::close(&mut out, slot);
        sections.finish(&mut out);
        assert_eq!(&out[4..], &[2, 7, 3, 0, 0, 0, 1, 2, 3, 200, 0, 0, 0, 0]);

        let mut r = Reader::new(&out);
        r.take(4, "head").unwrap();
        let mut read = read_sections(&mut r).unwrap();
        assert_eq!(read.len(), 2);
        assert_eq!(
            (read[0].kind, read[0].at, read[1].kind, read[1].at),
            (7, 5, 200, 13)
        );
        // Offsets inside a body count from the start of the message.
        assert_eq!(read[0].body.position(), 10);
        assert_eq!(read[0].body.take(3, "body").unwrap(), &[1, 2, 3]);
        assert!(matches!(
            read[1].body.u8("x"),
            Err(DecodeError::Truncated {
                field: "x",
                at: 18,
                ..
            })
        ));

        let mut long = out.clone();
        long[6] = 9;
        let mut r = Reader::new(&long);
        r.take(4, "head").unwrap();
        match read_sections(&mut r) {
            Err(DecodeError::Invalid {
                field: "section",
                at: 5,
                problem,
            }) => {
                assert!(problem.contains("kind 7 claims 9 bytes"), "{problem}")
            }
            other => panic!("{:?}", other.map(|s| s.len())),
        }
        let mut trailing = out.clone();
        trailing.push(0);
        let mut r = Reader::new(&trailing);
        r.take(4, "head").unwrap();
        assert!(matches!(
            read_sections(&mut r),
            Err(DecodeError::Trailing { extra: 1 })
        ));
    }
}
