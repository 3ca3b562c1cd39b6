"""glTF avatars as the server takes them: one ``.glb`` with everything inside.

A ``.gltf`` written with its buffers and images as files of their own (as "glTF Separate"
exports write them), or a ``.glb`` whose images are files beside it, is packed into one
``.glb`` here: every buffer laid end to end in one binary chunk (each 4-byte aligned) with
the buffer views moved along, and every image behind a URI given a view of its bytes and
its MIME type. ``data:`` URIs are decoded. The same packing as the page's "Your own head"
(``web/upload.js``), so a head registers the same from either.
"""

from __future__ import annotations

import base64
import copy
import json
import os
import struct
import urllib.parse
from typing import Any, Dict, List, Optional, Tuple

from .errors import FacewireError

GLB_MAGIC = 0x46546C67  # "glTF"
JSON_CHUNK = 0x4E4F534A  # "JSON"
BIN_CHUNK = 0x004E4942  # "BIN\0"
IMAGE_TYPES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}


def read_glb(data: bytes) -> Tuple[Dict[str, Any], Optional[bytes]]:
    """A ``.glb``'s JSON and its binary chunk (or ``None``)."""
    if len(data) < 20 or struct.unpack_from("<II", data, 0) != (GLB_MAGIC, 2):
        raise FacewireError("not a glTF 2.0 binary (.glb) file")
    json_length, kind = struct.unpack_from("<II", data, 12)
    if kind != JSON_CHUNK or 20 + json_length > len(data):
        raise FacewireError("a .glb whose first chunk is not its JSON")
    doc = json.loads(data[20:20 + json_length].decode("utf-8"))
    at = 20 + json_length
    binary = None
    if at + 8 <= len(data) and struct.unpack_from("<I", data, at + 4)[0] == BIN_CHUNK:
        length = struct.unpack_from("<I", data, at)[0]
        binary = data[at + 8:at + 8 + length]
    return doc, binary


def write_glb(doc: Dict[str, Any], binary: Optional[bytes]) -> bytes:
    """``doc`` and one binary chunk as a ``.glb`` (chunks padded to 4 bytes)."""
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    out = [b"", struct.pack("<II", len(text), JSON_CHUNK), text]
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        out += [struct.pack("<II", len(binary), BIN_CHUNK), binary]
    body = b"".join(out)
    return struct.pack("<III", GLB_MAGIC, 2, 12 + len(body)) + body


def _data_uri(uri: str) -> Tuple[bytes, str]:
    header, _, body = uri[5:].partition(",")
    if header.endswith(";base64"):
        return base64.b64decode(body), header[:-7] or "application/octet-stream"
    return urllib.parse.unquote_to_bytes(body), header or "application/octet-stream"


def pack_glb(doc: Dict[str, Any], binary: Optional[bytes], files: Dict[str, bytes]) -> bytes:
    """``doc`` (not changed) with what it names by URI put inside, as one ``.glb``: ``binary``
    is a ``.glb``'s own chunk (its first buffer without a URI), ``files`` maps file names to
    bytes for the URIs (matched by the URI's last path segment, decoded). Raises naming a
    file that is missing."""
    doc = copy.deepcopy(doc)

    def bytes_of(uri: str, what: str) -> Tuple[bytes, str]:
        if uri.startswith("data:"):
            return _data_uri(uri)
        name = urllib.parse.unquote(uri.replace("\\", "/").rsplit("/", 1)[-1])
        if name not in files:
            raise FacewireError("the glTF's %s is the file %r, which is not there" % (what, name))
        mime = IMAGE_TYPES.get(os.path.splitext(name)[1].lower(), "application/octet-stream")
        return files[name], mime

    packed = bytearray()

    def append(data: bytes) -> int:
        packed.extend(b"\0" * (-len(packed) % 4))
        offset = len(packed)
        packed.extend(data)
        return offset

    starts: List[int] = []
    for i, buffer in enumerate(doc.get("buffers") or []):
        if "uri" not in buffer:
            if binary is None:
                raise FacewireError("the glTF's buffer %d has no URI and there is no binary chunk" % i)
            starts.append(append(binary[:buffer.get("byteLength", len(binary))]))
        else:
            starts.append(append(bytes_of(buffer["uri"], "buffer %d" % i)[0]))
    for view in doc.get("bufferViews") or []:
        view["byteOffset"] = view.get("byteOffset", 0) + starts[view["buffer"]]
        view["buffer"] = 0
    for i, image in enumerate(doc.get("images") or []):
        if "uri" not in image:
            continue
        data, mime = bytes_of(image.pop("uri"), "image %d" % i)
        views = doc.get("bufferViews") or []
        doc["bufferViews"] = views
        views.append({"buffer": 0, "byteOffset": append(data), "byteLength": len(data)})
        image["bufferView"] = len(views) - 1
        image.setdefault("mimeType", mime)
    doc["buffers"] = [{"byteLength": len(packed)}] if packed else []
    return write_glb(doc, bytes(packed) if packed else None)


def avatar_file(path: str) -> bytes:
    """The ``.glb`` to register for the avatar at ``path``: a ``.glb`` with everything
    inside as it is; a ``.gltf``, or a ``.glb`` naming files by URI, packed with the files
    beside it."""
    with open(path, "rb") as f:
        data = f.read()
    if path.lower().endswith(".gltf"):
        doc, binary = json.loads(data.decode("utf-8")), None
    else:
        doc, binary = read_glb(data)
    named = [item["uri"] for item in (doc.get("buffers") or []) + (doc.get("images") or []) if "uri" in item]
    if not path.lower().endswith(".gltf") and not named:
        return data
    folder = os.path.dirname(os.path.abspath(path))
    files: Dict[str, bytes] = {}
    for uri in named:
        if uri.startswith("data:"):
            continue
        relative = urllib.parse.unquote(uri)
        name = relative.replace("\\", "/").rsplit("/", 1)[-1]
        full = os.path.join(folder, relative)
        if os.path.isfile(full):
            with open(full, "rb") as f:
                files[name] = f.read()
    return pack_glb(doc, binary, files)
