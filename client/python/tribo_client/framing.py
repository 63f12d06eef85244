"""Length-delimited frames: a base-128 varint byte count, then the message
(proto/framing.h). The size is checked against the maximum before the body is
read, as the daemon does."""

MAX_FRAME_BYTES = 4 << 20
MAX_VARINT_BYTES = 5


def encode_frame(message):
    body = message.SerializeToString()
    size = len(body)
    header = bytearray()
    while size >= 0x80:
        header.append((size & 0x7F) | 0x80)
        size >>= 7
    header.append(size)
    return bytes(header) + body


def read_exactly(sock, n):
    chunks = []
    while n > 0:
        chunk = sock.recv(min(n, 1 << 20))
        if not chunk:
            raise ConnectionError("connection to tribod closed")
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def read_frame(sock, max_frame_bytes=MAX_FRAME_BYTES):
    size = 0
    for i in range(MAX_VARINT_BYTES):
        byte = read_exactly(sock, 1)[0]
        size |= (byte & 0x7F) << (7 * i)
        if not byte & 0x80:
            break
    else:
        raise ConnectionError("invalid frame size prefix from tribod")
    if size > max_frame_bytes:
        raise ConnectionError(f"frame of {size} bytes exceeds the maximum of {max_frame_bytes}")
    return read_exactly(sock, size)
