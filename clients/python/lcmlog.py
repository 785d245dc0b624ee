"""Reads LCM event logs (the files lcm-logger and coopdyn's tests write) in pure Python.

An LCM log is a stream of records, each (big-endian)

    uint32 sync 0xEDA1DA01 | int64 event number | int64 timestamp (us since the epoch, when logged)
    | int32 channel length | int32 data length | channel (not NUL-terminated) | data

where data is one encoded message (its first 8 bytes the type's fingerprint). Installed as
coopdyn.lcmlog next to the generated message types; needs only the standard library.

    from coopdyn import lcmlog
    for e in lcmlog.read("run.lcmlog", channel="COOPDYN_OUTPUT"):
        msg = lcmlog.decode(e.data)        # a coopdyn.output_t (None: not a coopdyn type)
"""
import collections
import struct

SYNC = 0xEDA1DA01
_HEADER = struct.Struct(">IqqII")  # sync, event number, timestamp, channel length, data length
HEADER_BYTES = _HEADER.size       # 28
MAX_CHANNEL = 255                  # LCM allows 63; anything far longer is a corrupt header

Event = collections.namedtuple("Event", "eventnum timestamp channel data")


class LogError(ValueError):
    """A file that is not an LCM log, or a damaged record; the message names the file and byte offset."""


def read(path, channel=None):
    """Yields the log's events (Event: eventnum, timestamp in us, channel str, data bytes) in file order,
    only those on `channel` if given. Raises LogError naming the file and offset for a bad sync word, a
    channel name that is not text, or a record cut short (e.g. a logger killed while writing)."""
    with open(path, "rb") as f:
        offset = 0
        while True:
            head = f.read(_HEADER.size)
            if not head:
                return
            if len(head) < _HEADER.size:
                raise LogError("%s: byte %d: truncated record header (%d of %d bytes)"
                               % (path, offset, len(head), _HEADER.size))
            sync, eventnum, timestamp, clen, dlen = _HEADER.unpack(head)
            if sync != SYNC:
                raise LogError("%s: byte %d: not an LCM log record (sync word 0x%08X, expected 0x%08X)"
                               % (path, offset, sync, SYNC))
            if clen > MAX_CHANNEL:
                raise LogError("%s: byte %d: channel length %d: a damaged record" % (path, offset, clen))
            body = f.read(clen + dlen)
            if len(body) < clen + dlen:
                raise LogError("%s: byte %d: event %d cut short (%d of %d bytes)"
                               % (path, offset, eventnum, len(body), clen + dlen))
            try:
                name = body[:clen].decode("utf-8")
            except UnicodeDecodeError:
                raise LogError("%s: byte %d: channel name is not text" % (path, offset)) from None
            if channel is None or name == channel:
                yield Event(eventnum, timestamp, name, body[clen:])
            offset += _HEADER.size + clen + dlen


def write(f, events):
    """Writes events (Event or (eventnum, timestamp, channel, data)) to the binary file f in the same
    format, for tests and for cutting logs."""
    for eventnum, timestamp, name, data in events:
        c = name.encode("utf-8")
        f.write(_HEADER.pack(SYNC, eventnum, timestamp, len(c), len(data)))
        f.write(c)
        f.write(data)


def types():
    """{fingerprint bytes: class} of the coopdyn message types; output_v1_t is output_t as logs
    recorded before message version 2 carry it (wrenches as [mx my mz fx fy fz] lists), output_v2_t
    as logs of version 2 carry it (no wrench_sigma), output_v3_t as logs of version 3 (no
    wrench_bound), output_v4_t as logs of version 4 (no limits)."""
    import coopdyn
    return {t._get_packed_fingerprint(): t for t in (coopdyn.output_t, coopdyn.output_v4_t, coopdyn.output_v3_t,
                                                     coopdyn.output_v2_t, coopdyn.output_v1_t,
                                                     coopdyn.loop_stats_t,
                                                     coopdyn.torque_command_t, coopdyn.measured_state_t,
                                                     coopdyn.control_t)}


def components(w):
    """[mx, my, mz, fx, fy, fz] of a wrench of either output_t version (a wrench_t or a 6-list)."""
    return [w.mx, w.my, w.mz, w.fx, w.fy, w.fz] if hasattr(w, "mx") else list(w)


_TYPES = None


# The fingerprints of the inputs before they carried a MAC (mac_len, mac appended), by type name: such
# a message is the current one without its trailing mac_len 0, so logs recorded before still read.
_PRE_MAC = {bytes.fromhex("b5f5b8e960348f9c"): "torque_command_t", bytes.fromhex("1a87938cb56bb24b"): "measured_state_t",
            bytes.fromhex("489f6be38cd3846e"): "control_t"}

def _stats_missing():
    """{fingerprint: bytes} of loop_stats_t's older layouts (coopdyn.output_fields, generated from the
    daemon's field list): such a message lacks the int64 fields appended after it and reads as the
    current one with them 0 (as the C++ readers read it)."""
    from coopdyn import output_fields
    return {h: 8 * sum(1 for _, since in output_fields.STATS_FIELDS if since > v)
            for h, v in output_fields.STATS_LAYOUTS.items()}


_STATS_BEFORE = None


def decode(data):
    """The coopdyn message in data (by its fingerprint), decoded; None if it is another type."""
    global _TYPES, _STATS_BEFORE
    if _TYPES is None:
        _TYPES = types()
        _STATS_BEFORE = _stats_missing()
    head = bytes(data[:8])
    if head in _PRE_MAC:
        import coopdyn
        t = getattr(coopdyn, _PRE_MAC[head])
        return t.decode(t._get_packed_fingerprint() + bytes(data[8:]) + b"\0\0\0\0")
    if head in _STATS_BEFORE:
        import coopdyn
        t = coopdyn.loop_stats_t
        return t.decode(t._get_packed_fingerprint() + bytes(data[8:]) + bytes(_STATS_BEFORE[head]))
    t = _TYPES.get(head)
    return t.decode(data) if t else None


def upgrade(msg):
    """(output_t, missing): an output_t of any layout (output_v1_t .. output_v4_t, from decode) as the
    current output_t, and the set of the names of its fields the layout lacked: each holds its absent
    value (coopdyn.output_fields.OUTPUT_FIELDS: 0, -1, or zeros per wrench), version the layout's.
    The field list is the daemon's (service/io/codec/output_fields.def), as the C++ decode_output reads it."""
    import coopdyn
    from coopdyn import output_fields
    out, missing = coopdyn.output_t(), set()
    version = {"output_v1_t": 1, "output_v2_t": 2, "output_v3_t": 3, "output_v4_t": 4}.get(type(msg).__name__)
    count = {"one": lambda: 1, "four": lambda: 4, "wrenches": lambda: len(out.wrench_names),
             "contacts": lambda: len(out.contact_names), "stresses": lambda: len(out.stress_names),
             "constraints": lambda: len(out.constraint_names), "q": lambda: len(out.q_names),
             "v": lambda: len(out.v_names), "free": lambda: len(out.free_class)}

    def wrench(w):
        if hasattr(w, "mx"):
            return w
        r = coopdyn.wrench_t()
        r.mx, r.my, r.mz, r.fx, r.fy, r.fz = components(w)
        return r

    for name, typ, size, since, absent in output_fields.OUTPUT_FIELDS:
        if hasattr(msg, name):
            v = getattr(msg, name)
            if typ == "wrenches":
                v = [wrench(w) for w in v]
            elif typ == "dirs":
                v = [[wrench(w) for w in d] for d in v]
            setattr(out, name, v)
            continue
        missing.add(name)
        n = count[size]() if size in count else 0
        if name == "version" and version is not None:
            v = version
        elif typ == "wrenches":
            v = [wrench([absent] * 6) for _ in range(n)]
        elif size == "one":
            v = absent
        else:
            v = [absent] * n
        setattr(out, name, v)
    return out, missing
