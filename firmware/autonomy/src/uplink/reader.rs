//! The uplink's element reader: postcard decoded field by field, so that a list over its
//! capacity or a field that does not decode is refused with its own code and site.

use super::*;

/// Reads elements off an uplink, one at a time.
pub(super) struct Reader<'a> {
    pub(super) rest: &'a [u8],
}

impl<'a> Reader<'a> {
    pub(super) fn take<T: DeserializeOwned>(
        &mut self,
        site: ErrorSite,
    ) -> Result<T, ValidationError> {
        match postcard::take_from_bytes::<T>(self.rest) {
            Ok((value, rest)) => {
                self.rest = rest;
                Ok(value)
            }
            Err(_) => Err(ValidationError::new(ValidationCode::Decode, site)),
        }
    }

    /// A `u64` as postcard writes it (a varint of at most 10 bytes, the last at most 1), read
    /// here rather than through `take` (a deserializer built and finished for every number):
    /// the same numbers, and `Decode` where postcard fails (a short or over-long varint).
    ///
    /// A one-byte varint is read without a loop; in a longer one the seven-bit groups are
    /// gathered four at a time into a 32-bit word, which is shifted into place once (a 64-bit
    /// shift by a variable amount takes about a dozen instructions on the 32-bit target): a
    /// checkpoint's network is hundreds of varints.
    pub(super) fn u64(&mut self, site: ErrorSite) -> Result<u64, ValidationError> {
        // One byte (lengths, counts, small numbers): no loop.
        match self.rest.split_first() {
            Some((&byte, rest)) if byte & 0x80 == 0 => {
                self.rest = rest;
                Ok(u64::from(byte))
            }
            _ => self.u64_long(site),
        }
    }

    /// [`Reader::u64`] of a varint of more than one byte (or none). Bytes 1 to 3 are taken
    /// one by one with constant shifts into the low 28 bits (the times and durations of a
    /// network are mostly five bytes long), the rest a group of four at a time.
    #[inline(never)]
    pub(super) fn u64_long(&mut self, site: ErrorSite) -> Result<u64, ValidationError> {
        const MAX_BYTES: usize = 10;
        let error = ValidationError::new(ValidationCode::Decode, site);
        let rest = self.rest;
        let byte = |i: usize| rest.get(i).copied().ok_or(error);
        let done = |reader: &mut Self, used: usize, value: u64| {
            reader.rest = rest.get(used..).unwrap_or(&[]);
            Ok(value)
        };
        // The first byte has its continuation bit set (or is absent).
        let b = byte(0)?;
        let mut low = u32::from(b & 0x7F);
        if b & 0x80 == 0 {
            return done(self, 1, u64::from(low));
        }
        let b = byte(1)?;
        low |= u32::from(b & 0x7F) << 7;
        if b & 0x80 == 0 {
            return done(self, 2, u64::from(low));
        }
        let b = byte(2)?;
        low |= u32::from(b & 0x7F) << 14;
        if b & 0x80 == 0 {
            return done(self, 3, u64::from(low));
        }
        let b = byte(3)?;
        low |= u32::from(b & 0x7F) << 21;
        if b & 0x80 == 0 {
            return done(self, 4, u64::from(low));
        }
        // Bytes 4 to 9: groups of four from bit 28.
        let mut value = u64::from(low);
        let mut i = 4usize;
        for group in 1..3u32 {
            let mut word = 0u32;
            for k in 0..4u32 {
                if i == MAX_BYTES {
                    return Err(error);
                }
                let b = byte(i)?;
                word |= u32::from(b & 0x7F) << (7 * k);
                i += 1;
                if b & 0x80 == 0 {
                    if i == MAX_BYTES && b > 0x01 {
                        return Err(error);
                    }
                    return done(self, i, value | (u64::from(word) << (28 * group)));
                }
            }
            value |= u64::from(word) << (28 * group);
        }
        Err(error)
    }

    /// A `u8` as postcard writes it: the byte itself (`Decode` when there is none). Read here
    /// rather than through `take`, whose deserializer costs about 90 instructions a number.
    pub(super) fn byte(&mut self, site: ErrorSite) -> Result<u8, ValidationError> {
        let (&b, rest) = self
            .rest
            .split_first()
            .ok_or(ValidationError::new(ValidationCode::Decode, site))?;
        self.rest = rest;
        Ok(b)
    }

    /// A `u16` as postcard writes it: a varint of at most three bytes, the third at most 3
    /// (what postcard refuses, a longer or larger one or too few bytes, is `Decode`).
    pub(super) fn u16(&mut self, site: ErrorSite) -> Result<u16, ValidationError> {
        let mut value = 0u16;
        for i in 0..3u32 {
            let b = self.byte(site)?;
            value |= u16::from(b & 0x7F) << (7 * i);
            if b & 0x80 == 0 {
                if i == 2 && b > 0x03 {
                    break;
                }
                return Ok(value);
            }
        }
        Err(ValidationError::new(ValidationCode::Decode, site))
    }

    /// An `i64` as postcard writes it (zigzag, then a varint), read with [`Reader::u64`].
    pub(super) fn i64(&mut self, site: ErrorSite) -> Result<i64, ValidationError> {
        let z = self.u64(site)?;
        Ok(((z >> 1) as i64) ^ -((z & 1) as i64))
    }

    /// A `bool` as postcard writes it (one byte, 0 or 1; anything else does not decode).
    pub(super) fn bool(&mut self, site: ErrorSite) -> Result<bool, ValidationError> {
        match self.rest.split_first() {
            Some((&b, rest)) if b <= 1 => {
                self.rest = rest;
                Ok(b == 1)
            }
            _ => Err(ValidationError::new(ValidationCode::Decode, site)),
        }
    }

    /// A mission time (a `u64` newtype: postcard writes the number alone).
    pub(super) fn time(&mut self, site: ErrorSite) -> Result<MissionTimeUs, ValidationError> {
        self.u64(site).map(MissionTimeUs)
    }

    /// The length postcard puts before a list or a string (a varint). Read as a `u64` on
    /// every platform, so a length says the same on the 32-bit target as on the host.
    pub(super) fn length(&mut self, site: ErrorSite) -> Result<usize, ValidationError> {
        let n = self.u64(site)?;
        Ok(usize::try_from(n).unwrap_or(usize::MAX))
    }

    /// A top-level element count (`u16`), at most `max`. Over it: `too_many` at the site of
    /// the first element that does not fit.
    /// Clears `list` and reads a count (at most the list's capacity, else `too_many`) and that
    /// many elements into it with `item` (given the element's index).
    pub(super) fn refill<T, const N: usize>(
        &mut self,
        list: &mut Vec<T, N>,
        too_many: ValidationCode,
        mut item: impl FnMut(&mut Self, usize) -> Result<T, ValidationError>,
    ) -> VResult {
        list.clear();
        for i in 0..self.count(N, too_many, ErrorSite::Network)? {
            let element = item(self, i)?;
            list.push(element)
                .map_err(|_| ValidationError::new(too_many, ErrorSite::Network))?;
        }
        Ok(())
    }

    pub(super) fn count(
        &mut self,
        max: usize,
        too_many: ValidationCode,
        first_over: ErrorSite,
    ) -> Result<usize, ValidationError> {
        let n = self.u16(ErrorSite::Network)?;
        let n = usize::from(n);
        if n > max {
            return Err(ValidationError::new(too_many, first_over));
        }
        Ok(n)
    }

    /// A list nested in an element, of at most `N` items; item `i` is at `site(i)`. A longer
    /// list is refused with `too_many` at the site of the first item that does not fit,
    /// before any item is decoded.
    pub(super) fn list<T: DeserializeOwned, const N: usize>(
        &mut self,
        too_many: ValidationCode,
        site: impl Fn(usize) -> ErrorSite,
    ) -> Result<Vec<T, N>, ValidationError> {
        let n = self.length(site(0))?;
        if n > N {
            return Err(ValidationError::new(too_many, site(N)));
        }
        let mut items = Vec::new();
        for i in 0..n {
            let item = self.take(site(i))?;
            items
                .push(item)
                .map_err(|_| ValidationError::new(too_many, site(i)))?;
        }
        Ok(items)
    }

    /// [`Reader::list`] into `items` in place (cleared first): the items are not built in a
    /// temporary list that is then moved, twice, into the element that holds it.
    pub(super) fn list_into<T: DeserializeOwned, const N: usize>(
        &mut self,
        items: &mut Vec<T, N>,
        too_many: ValidationCode,
        site: impl Fn(usize) -> ErrorSite,
    ) -> Result<(), ValidationError> {
        items.clear();
        let n = self.length(site(0))?;
        if n > N {
            return Err(ValidationError::new(too_many, site(N)));
        }
        for i in 0..n {
            let item = self.take(site(i))?;
            items
                .push(item)
                .map_err(|_| ValidationError::new(too_many, site(i)))?;
        }
        Ok(())
    }

    /// A name: over [`MAX_NAME_LEN`] bytes is [`ValidationCode::NameTooLong`].
    /// Read here as postcard reads a string (length, then UTF-8 bytes) but straight into the
    /// [`Name`], without postcard's string visitor and the moves of its result.
    pub(super) fn name(&mut self, site: ErrorSite) -> Result<Name, ValidationError> {
        let mut name = Name::new();
        self.name_into(site, &mut name)?;
        Ok(name)
    }

    /// [`Reader::name`] into `name` (cleared first), not returned and moved.
    pub(super) fn name_into(&mut self, site: ErrorSite, name: &mut Name) -> VResult {
        name.clear();
        let len = self.length(site)?;
        if len > MAX_NAME_LEN {
            return Err(ValidationError::new(ValidationCode::NameTooLong, site));
        }
        let decode_error = ValidationError::new(ValidationCode::Decode, site);
        let (bytes, rest) = self.rest.split_at_checked(len).ok_or(decode_error)?;
        let text = core::str::from_utf8(bytes).map_err(|_| decode_error)?;
        name.push_str(text).map_err(|_| decode_error)?;
        self.rest = rest;
        Ok(())
    }

    /// An `Option` (postcard: a tag byte 0 or 1, then the value) whose value `read` decodes.
    pub(super) fn option<T>(
        &mut self,
        site: ErrorSite,
        read: impl FnOnce(&mut Self) -> Result<T, ValidationError>,
    ) -> Result<Option<T>, ValidationError> {
        match self.byte(site)? {
            0 => Ok(None),
            1 => read(self).map(Some),
            _ => Err(ValidationError::new(ValidationCode::Decode, site)),
        }
    }

    pub(super) fn command(&mut self, site: ErrorSite) -> Result<CommandSpec, ValidationError> {
        let opcode = self.take(site)?;
        let args = self.list(ValidationCode::TooManyCommandArgs, |_| site)?;
        let from_instance = self.list(ValidationCode::TooManyCommandArgs, |_| site)?;
        Ok(CommandSpec {
            opcode,
            args,
            from_instance,
        })
    }

    /// Timeline `index`, decoded into `timelines` (pushed at its end): the name and the
    /// thresholds are read straight into the pushed element, the other fields assigned to it,
    /// so nothing is built in a temporary and moved (each move a `memcpy` call on the target).
    /// On error `timelines` may hold a partly decoded last element (the caller discards the
    /// network).
    pub(super) fn timeline_into<const N: usize>(
        &mut self,
        index: usize,
        timelines: &mut Vec<TimelineSpec, N>,
    ) -> Result<(), ValidationError> {
        let site = ErrorSite::Timeline(u8_index(index));
        timelines
            .push(TimelineSpec {
                name: Name::new(),
                kind: TimelineKind::Claimable,
                state_key: None,
                after_reset: None,
                stale_after_us: None,
                background_rate: 0,
                external: false,
                thresholds: Vec::new(),
            })
            .map_err(|_| ValidationError::new(ValidationCode::TooManyTimelines, site))?;
        let Some(t) = timelines.last_mut() else {
            return Err(ValidationError::new(ValidationCode::TooManyTimelines, site));
        };
        self.name_into(site, &mut t.name)?;
        t.kind = self.take(site)?;
        t.state_key = self.take(site)?;
        let after_reset_site = ErrorSite::TimelineAfterReset(u8_index(index));
        t.after_reset = self.option(after_reset_site, |r| r.i64(after_reset_site))?;
        let stale_site = ErrorSite::TimelineStaleAfter(u8_index(index));
        t.stale_after_us = self.option(stale_site, |r| r.u64(stale_site))?;
        t.background_rate = self.i64(site)?;
        t.external = self.bool(site)?;
        self.list_into(&mut t.thresholds, ValidationCode::TooManyThresholds, |_| {
            ErrorSite::TimelineThresholds(u8_index(index))
        })
    }

    /// Timeline `index` as a value ([`Reader::timeline_into`] into a list of one).
    pub(super) fn timeline(&mut self, index: usize) -> Result<TimelineSpec, ValidationError> {
        let mut one: Vec<TimelineSpec, 1> = Vec::new();
        self.timeline_into(index, &mut one)?;
        one.pop().ok_or(ValidationError::new(
            ValidationCode::Decode,
            ErrorSite::Timeline(u8_index(index)),
        ))
    }

    pub(super) fn condition(&mut self, index: usize) -> Result<ConditionSpec, ValidationError> {
        let condition = u8_index(index);
        let nodes = self.list(ValidationCode::TooManyConditionTerms, |node| {
            ErrorSite::Condition {
                condition,
                node: u8_index(node),
            }
        })?;
        Ok(ConditionSpec { nodes })
    }

    /// Task `index`, decoded into `tasks` (pushed at its end): the fields before the first
    /// list are read into the pushed element, and the lists and the control part that follow
    /// are decoded straight into it, so the element is copied once (by the push) instead of
    /// being built in temporaries and moved through each reader's result. On error `tasks`
    /// may hold a partly decoded last element (the caller discards the network).
    pub(super) fn task_into<const N: usize>(
        &mut self,
        index: usize,
        tasks: &mut Vec<TaskSpec, N>,
    ) -> Result<(), ValidationError> {
        use ValidationCode::*;
        let task = u16_index(index);
        let site = |field| ErrorSite::Task { task, field };
        let id = self.u16(site(TaskField::Id))?;
        let name = self.name(site(TaskField::Name))?;
        let priority = self.byte(site(TaskField::Whole))?;
        let role = self.take(site(TaskField::Whole))?;
        let command = self.option(site(TaskField::Command), |r| {
            r.command(site(TaskField::Command))
        })?;
        let duration_us = self.u64(site(TaskField::Duration))?;
        let min_duration_us = self.u64(site(TaskField::Duration))?;
        let earliest_start = self.time(site(TaskField::Window))?;
        let latest_start = self.time(site(TaskField::Window))?;
        let latest_end = self.time(site(TaskField::Window))?;
        tasks
            .push(TaskSpec {
                id,
                name,
                priority,
                role,
                command,
                duration_us,
                min_duration_us,
                earliest_start,
                latest_start,
                latest_end,
                constraints: Vec::new(),
                impacts: Vec::new(),
                control: ControlSpec::NONE,
                contingencies: Vec::new(),
                permissions: Permissions {
                    may_move: false,
                    may_delete: false,
                    may_add: Vec::new(),
                },
            })
            .map_err(|_| ValidationError::new(TooManyTasks, site(TaskField::Whole)))?;
        let Some(t) = tasks.last_mut() else {
            return Err(ValidationError::new(TooManyTasks, site(TaskField::Whole)));
        };
        self.list_into(&mut t.constraints, TooManyConstraints, |k| {
            site(TaskField::Constraint(u8_index(k)))
        })?;
        self.list_into(&mut t.impacts, TooManyImpacts, |k| {
            site(TaskField::Impact(u8_index(k)))
        })?;
        self.control_into(|field| ErrorSite::Task { task, field }, &mut t.control)?;
        self.list_into(&mut t.contingencies, TooManyContingencies, |k| {
            site(TaskField::Contingency(u8_index(k)))
        })?;
        t.permissions.may_move = self.bool(site(TaskField::Whole))?;
        t.permissions.may_delete = self.bool(site(TaskField::Whole))?;
        self.list_into(&mut t.permissions.may_add, TooManyPermissions, |k| {
            site(TaskField::Permission(u8_index(k)))
        })?;
        Ok(())
    }

    /// Task `index` as a value ([`Reader::task_into`] into a list of one).
    pub(super) fn task(&mut self, index: usize) -> Result<TaskSpec, ValidationError> {
        let mut one: Vec<TaskSpec, 1> = Vec::new();
        self.task_into(index, &mut one)?;
        one.pop().ok_or(ValidationError::new(
            ValidationCode::Decode,
            ErrorSite::Task {
                task: u16_index(index),
                field: TaskField::Whole,
            },
        ))
    }

    /// [`Reader::control`] into `c` in place, field by field.
    pub(super) fn control_into(
        &mut self,
        site: impl Fn(TaskField) -> ErrorSite,
        c: &mut ControlSpec,
    ) -> Result<(), ValidationError> {
        let control = site(TaskField::Control);
        let responses = |f| site(TaskField::Responses(f));
        c.start_condition = self.option(control, |r| r.byte(control))?;
        c.maintain_condition = self.option(control, |r| r.byte(control))?;
        c.skip_condition = self.option(control, |r| r.byte(control))?;
        c.pre_wait_timeout_us = self.u64(control)?;
        c.response_timeout_us = self.u64(control)?;
        c.on_failure_command = self.option(control, |r| r.command(control))?;
        c.max_retries = self.take(responses(ResponseField::MaxRetries))?;
        c.max_repairs = self.take(responses(ResponseField::MaxRepairs))?;
        c.backoff = self.take(responses(ResponseField::Backoff))?;
        Ok(())
    }
}

/// Decodes one timeline (element `index` of the uplink) off the front of `bytes`; returns it
/// and the bytes after it. The uplink decoder's own element reader: a name over
/// [`MAX_NAME_LEN`] is [`ValidationCode::NameTooLong`], anything else that does not decode
/// [`ValidationCode::Decode`], at the timeline's site. Decodes exactly what postcard decodes
/// into a [`TimelineSpec`] (the fuzz targets check that).
pub fn take_timeline(bytes: &[u8], index: usize) -> Result<(TimelineSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let t = r.timeline(index)?;
    Ok((t, r.rest))
}

/// Decodes one condition (element `index`); more than [`MAX_CONDITION_TERMS`] nodes is
/// [`ValidationCode::TooManyConditionTerms`] at the first node that does not fit.
pub fn take_condition(
    bytes: &[u8],
    index: usize,
) -> Result<(ConditionSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let c = r.condition(index)?;
    Ok((c, r.rest))
}

/// Decodes one task (element `index`). A list over its capacity is refused with its own code
/// (`TooManyConstraints`, `TooManyImpacts`, `TooManyContingencies`, `TooManyPermissions`,
/// `TooManyCommandArgs`) at the site of the first item that does not fit, a name over
/// [`MAX_NAME_LEN`] with `NameTooLong`; any other defect is `Decode` at the field it is in.
pub fn take_task(bytes: &[u8], index: usize) -> Result<(TaskSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let t = r.task(index)?;
    Ok((t, r.rest))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    /// What `Reader::u64` reads off `bytes`: the value and the bytes left, or None.
    fn ours(bytes: &[u8]) -> Option<(u64, usize)> {
        let mut r = Reader { rest: bytes };
        r.u64(ErrorSite::Network).ok().map(|v| (v, r.rest.len()))
    }

    #[test]
    fn i64_and_bool_read_what_postcard_reads() {
        for v in [
            0i64,
            1,
            -1,
            63,
            -64,
            64,
            -65,
            1 << 40,
            -(1 << 48),
            i64::MAX,
            i64::MIN,
        ] {
            let mut buf = [0u8; 16];
            let read = postcard::to_slice(&v, &mut buf).ok().map(|bytes| {
                let mut r = Reader { rest: bytes };
                (r.i64(ErrorSite::Network).ok(), r.rest.len())
            });
            assert_eq!(read, Some((Some(v), 0)));
        }
        for b in 0u8..=255 {
            let ours = Reader { rest: &[b] }.bool(ErrorSite::Network).ok();
            let theirs = postcard::from_bytes::<bool>(&[b]).ok();
            assert_eq!(ours, theirs, "byte {b}");
        }
    }

    /// What postcard reads off `bytes` as a `u64`.
    fn postcards(bytes: &[u8]) -> Option<(u64, usize)> {
        postcard::take_from_bytes::<u64>(bytes)
            .ok()
            .map(|(v, rest)| (v, rest.len()))
    }

    #[test]
    fn the_varint_reader_reads_what_postcard_reads() {
        let mut cases: std::vec::Vec<std::vec::Vec<u8>> = std::vec::Vec::new();
        // Every power of two and its neighbours, each followed by a byte that must be left.
        for shift in 0..64 {
            for v in [
                1u64 << shift,
                (1u64 << shift) - 1,
                (1u64 << shift) + 1,
                u64::MAX,
            ] {
                let mut buf = [0u8; 16];
                let used = postcard::to_slice(&v, &mut buf).map_or(0, |b| b.len());
                assert!(used > 0, "{v} encodes");
                let mut bytes = buf.get(..used).unwrap_or(&[]).to_vec();
                bytes.push(0x55);
                cases.push(bytes.clone());
                // Every truncation of it.
                for cut in 0..used {
                    cases.push(bytes.get(..cut).unwrap_or(&[]).to_vec());
                }
            }
        }
        // Ten bytes whose last carries more than the one bit left, and eleven-byte varints.
        for last in 0..=0xFFu8 {
            let mut bytes = [0xFFu8; 9].to_vec();
            bytes.push(last);
            cases.push(bytes.clone());
            bytes.push(0x00);
            cases.push(bytes);
        }
        // Over-long encodings of small numbers (a zero continuation), which postcard takes.
        cases.push(std::vec![0x80, 0x00]);
        cases.push(std::vec![0x81, 0x80, 0x00, 0x07]);
        for bytes in &cases {
            assert_eq!(ours(bytes), postcards(bytes), "{bytes:02x?}");
        }
        assert_eq!(ours(&[0xFF; 9]), None);
        assert_eq!(ours(&[0x80, 0x00]), Some((0, 0)));
        assert_eq!(ours(&[0xFF, 0x01, 0x55]), Some((255, 1)));
    }
}
