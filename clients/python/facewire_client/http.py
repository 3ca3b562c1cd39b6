"""The HTTP resources: heads, meshes, batches (:class:`Client`)."""

from __future__ import annotations

import base64
import json
import math
import os
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import TYPE_CHECKING, Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union, cast

from ._socket import _base_urls, _segment
from .audio import _pcm_samples, _wav_file
from .gltf_pack import avatar_file
from .errors import FacewireError, FrameError, HttpError, ProtocolError
from .producer_frames import encode_json
from .viewer_frames import RestMesh, decode_mesh

if TYPE_CHECKING:
    from .producer import Producer
    from .viewer import Viewer


class Client:
    """The HTTP side of a facewire server.

    ``url`` is the server's base URL (``http://127.0.0.1:8480``). ``token``, when the
    server is configured with tokens, goes in an ``Authorization: Bearer`` header on every
    request; calls that need another one (admin, producer) take ``token=`` themselves."""

    def __init__(self, url: str, token: Optional[str] = None, timeout: float = 30.0):
        self.url, self.ws_url = _base_urls(url)
        self.token = token
        self.timeout = timeout

    def request(self, method: str, path: str, body: Optional[bytes] = None,
                content_type: Optional[str] = None,
                token: Optional[str] = None,
                headers: Optional[Mapping[str, str]] = None) -> Tuple[int, bytes]:
        """One HTTP request; returns (status, body) or raises :class:`HttpError`."""
        url = self.url + path
        request = urllib.request.Request(url, data=body, method=method)
        token = token if token is not None else self.token
        if token:
            request.add_header("Authorization", "Bearer " + token)
        if content_type:
            request.add_header("Content-Type", content_type)
        for name, value in (headers or {}).items():
            request.add_header(name, value)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as e:
            raw = e.read()
            code, message = "http_%d" % e.code, raw.decode("utf-8", "replace").strip()
            try:
                parsed = json.loads(raw)
                if isinstance(parsed, dict):
                    code = str(parsed.get("error", code))
                    message = str(parsed.get("message", message))
            except ValueError:
                pass
            raise HttpError(method, url, e.code, code, message or str(e.reason)) from None
        except urllib.error.URLError as e:
            raise FacewireError("%s %s: cannot reach the server: %s" % (method, url, e.reason)) from None
        except OSError as e:
            raise FacewireError("%s %s: %s" % (method, url, e)) from None

    def _json(self, method: str, path: str, payload: Any = None,
              token: Optional[str] = None) -> Any:
        body = None if payload is None else json.dumps(payload).encode("utf-8")
        _, raw = self.request(method, path, body, "application/json" if body else None, token)
        try:
            return json.loads(raw) if raw else None
        except ValueError:
            raise ProtocolError("%s %s: the answer is not JSON: %r" % (method, path, raw[:200])) from None

    def health(self) -> Dict[str, Any]:
        """``GET /healthz``: ``{"status": "ok", "heads": N, "uptime_s": S}``."""
        return cast(Dict[str, Any], self._json("GET", "/healthz"))

    def algorithms(self) -> List[Dict[str, Any]]:
        """``GET /v1/algorithms``: presets with letter, spec, linear, description, default."""
        return cast(List[Dict[str, Any]], self._json("GET", "/v1/algorithms"))

    def list_heads(self) -> List[Dict[str, Any]]:
        """``GET /v1/heads``: head info of every registered head."""
        return cast(List[Dict[str, Any]], self._json("GET", "/v1/heads"))

    def head(self, head_id: str) -> Dict[str, Any]:
        """``GET /v1/heads/{id}``: id, vertices, triangles, mm_per_unit, status, progress,
        error, streams, algorithms."""
        return cast(Dict[str, Any], self._json("GET", "/v1/heads/" + _segment(head_id)))

    def register_head(self, head_id: str, obj: str, *, fit: Optional[str] = None,
                      landmarks: Optional[str] = None, producer_token: Optional[str] = None,
                      token: Optional[str] = None,
                      parts: Optional[Sequence[Tuple[str, str, Optional[str]]]] = None,
                      texture: Optional[bytes] = None) -> Dict[str, Any]:
        """``POST /v1/heads`` with the OBJ text and at most one of ``fit`` (a ``.fit.toml``
        text) or ``landmarks`` (a ``.landmarks.toml`` text, the server solves the fit); with
        neither, the server finds the face itself (the automatic fit). ``parts`` are the
        head's part meshes as ``(name, obj text, role)`` with role ``"skull"``, ``"jaw"``,
        ``"tongue"``, ``"eyes"`` or ``None`` (the server infers skull or jaw). ``texture``
        is the head's texture image, PNG or JPEG bytes, drawn with the OBJ's texture
        coordinates (``vt`` and ``f v/vt``). Registration runs in the background: follow
        with :meth:`wait_ready`. ``token`` is the admin token."""
        if fit is not None and landmarks is not None:
            raise FacewireError("register_head: give at most one of fit and landmarks")
        payload: Dict[str, Any] = {"id": head_id, "obj": obj}
        if parts:
            payload["parts"] = [dict({"name": name, "obj": text}, **({"role": role} if role else {}))
                                for name, text, role in parts]
        if fit is not None:
            payload["fit"] = fit
        if landmarks is not None:
            payload["landmarks"] = landmarks
        if producer_token is not None:
            payload["producer_token"] = producer_token
        if texture is not None:
            payload["texture"] = base64.b64encode(texture).decode("ascii")
        return cast(Dict[str, Any], self._json("POST", "/v1/heads", payload, token))

    def register_glb(self, head_id: str, glb: bytes, *, roles: Optional[Mapping[str, str]] = None,
                     producer_token: Optional[str] = None,
                     token: Optional[str] = None) -> Dict[str, Any]:
        """``POST /v1/heads?id=`` with a glTF binary avatar (the ``.glb`` file's bytes): the
        server finds the skin, teeth, tongue and eyes by their names (``roles`` maps a
        mesh's name to ``"skin"``, ``"part"``, ``"skull"``, ``"jaw"``, ``"tongue"``,
        ``"eyes"`` or ``"none"`` where its name does not say it), takes metres from the
        format and fits the face itself. The answer's ``source`` says which mesh became
        what. ``token`` is the admin token."""
        query = {"id": head_id}
        if roles:
            query["roles"] = ",".join("%s=%s" % (mesh, role) for mesh, role in roles.items())
        headers = {"X-Facewire-Producer-Token": producer_token} if producer_token else None
        _, raw = self.request("POST", "/v1/heads?" + urllib.parse.urlencode(query), glb,
                              "model/gltf-binary", token, headers)
        try:
            return cast(Dict[str, Any], json.loads(raw))
        except ValueError:
            raise ProtocolError("POST /v1/heads: the answer is not JSON: %r" % raw[:200]) from None

    def register_avatar_file(self, head_id: str, path: str, *, roles: Optional[Mapping[str, str]] = None,
                             producer_token: Optional[str] = None,
                             token: Optional[str] = None) -> Dict[str, Any]:
        """:meth:`register_glb` with the avatar at ``path``: a ``.glb``, or a ``.gltf`` (or a
        ``.glb`` naming images by URI) packed into one ``.glb`` with the files beside it
        (:func:`facewire_client.avatar_file`)."""
        return self.register_glb(head_id, avatar_file(path), roles=roles,
                                 producer_token=producer_token, token=token)

    def register_head_files(self, head_id: str, obj_path: str, *, fit_path: Optional[str] = None,
                            landmarks_path: Optional[str] = None,
                            producer_token: Optional[str] = None,
                            token: Optional[str] = None,
                            texture_path: Optional[str] = None) -> Dict[str, Any]:
        """:meth:`register_head` with the texts read from files, and the texture: the file
        ``texture_path``, else the image the OBJ's material names (its ``mtllib`` file's
        first ``map_Kd``, both beside the OBJ), else none."""

        def read(path: Optional[str]) -> Optional[str]:
            if path is None:
                return None
            with open(path, "r", encoding="utf-8") as f:
                return f.read()

        obj = read(obj_path)
        assert obj is not None
        if texture_path is None:
            texture_path = material_texture(obj, os.path.dirname(os.path.abspath(obj_path)))
        texture = None
        if texture_path is not None:
            with open(texture_path, "rb") as f:
                texture = f.read()
        return self.register_head(head_id, obj, fit=read(fit_path), landmarks=read(landmarks_path),
                                  producer_token=producer_token, token=token, texture=texture)

    def wait_ready(self, head_id: str, timeout: float = 300.0, poll_s: float = 0.1) -> Dict[str, Any]:
        """Polls ``GET /v1/heads/{id}`` until ``status`` is ``ready`` and returns the head
        info; raises :class:`FacewireError` if registration failed or took too long."""
        deadline = time.monotonic() + timeout
        while True:
            info = self.head(head_id)
            status = info.get("status")
            if status == "ready":
                return info
            if status == "failed":
                raise FacewireError("head %r failed to register: %s" % (head_id, info.get("error")))
            if time.monotonic() >= deadline:
                raise FacewireError("head %r is still %s (%.0f %%) after %.0f s"
                                    % (head_id, status, 100 * float(info.get("progress", 0)), timeout))
            time.sleep(poll_s)

    def delete_head(self, head_id: str, token: Optional[str] = None) -> None:
        """``DELETE /v1/heads/{id}`` (admin token); its streams end."""
        self.request("DELETE", "/v1/heads/" + _segment(head_id), token=token)

    def mesh(self, head_id: str) -> RestMesh:
        """``GET /v1/heads/{id}/mesh.bin``, decoded."""
        return self.mesh_at("/v1/heads/%s/mesh.bin" % _segment(head_id))

    def mesh_at(self, path: str) -> RestMesh:
        """The rest mesh at a server path (a snapshot's ``rest_mesh``, a part's
        ``mesh``), decoded."""
        _, raw = self.request("GET", path)
        return decode_mesh(raw)

    def part_mesh(self, head_id: str, name: str) -> RestMesh:
        """``GET /v1/heads/{id}/parts/{name}/mesh.bin``: a part's rest mesh, decoded
        (head units, in the head's frame). 404 ``not_found`` for a name the head has not."""
        return self.mesh_at("/v1/heads/%s/parts/%s/mesh.bin" % (_segment(head_id), _segment(name)))

    def post_batch(self, head_id: str, stream: str,
                   frames: Union[None, str, bytes, Iterable[Mapping[str, Any]]] = None, *,
                   fap: bool = False, token: Optional[str] = None,
                   audio: Union[None, str, "os.PathLike[str]", Sequence[int], bytes, bytearray] = None,
                   sample_rate: int = 16000, audio_t_s: Optional[float] = None) -> Dict[str, Any]:
        """``POST .../streams/{stream}/batch``: a whole stream, played by the server at its
        timestamps. ``frames`` is JSONL text or bytes, or frame mappings (written as
        JSONL); ``fap=True`` sends an MPEG-4 ``.fap`` file's text instead.

        ``audio`` is the stream's voice, played with the frames on their clock: a WAV
        file's path (the server takes any PCM or float WAV at 16, 24 or 48 kHz, mixed to
        mono), or 16-bit mono samples at ``sample_rate`` (integers, or ``bytes`` of
        little-endian i16). Its first sample plays at ``audio_t_s`` (by default the first
        frame's ``t``). With ``audio``, ``frames`` may be left out: a voice alone.

        Returns ``{"frames": N, "duration_s": S, "audio_s": A}``; errors name the part,
        line and field (400 ``bad_frame``). ``token`` is the producer token."""
        if frames is None and audio is None:
            raise FrameError("post_batch: give frames, audio or both")
        body: Optional[bytes] = None
        if isinstance(frames, bytes):
            body = frames
        elif isinstance(frames, str):
            body = frames.encode("utf-8")
        elif frames is not None:
            body = "".join(encode_json(f) + "\n" for f in frames).encode("utf-8")
        path = "/v1/heads/%s/streams/%s/batch" % (_segment(head_id), _segment(stream))
        stream_type = "application/x-fap" if fap else "application/x-ndjson"
        if audio is None:
            _, raw = self.request("POST", path, body, stream_type, token)
            return cast(Dict[str, Any], json.loads(raw))
        parts: List[Tuple[str, Optional[str], str, bytes]] = []
        if body is not None:
            parts.append(("stream", "stream.fap" if fap else "stream.jsonl", stream_type, body))
        if isinstance(audio, (str, os.PathLike)):
            with open(os.fspath(audio), "rb") as f:
                wav_file = f.read()
        else:
            wav_file = _wav_file(_pcm_samples(audio_t_s or 0.0, audio), sample_rate)
        parts.append(("audio", "audio.wav", "audio/wav", wav_file))
        if audio_t_s is not None:
            if (isinstance(audio_t_s, bool) or not isinstance(audio_t_s, (int, float))
                    or not math.isfinite(audio_t_s)):
                raise FrameError("post_batch: audio_t_s %r is not a finite number of seconds"
                                 % (audio_t_s,))
            parts.append(("audio_t_s", None, "text/plain", repr(float(audio_t_s)).encode("ascii")))
        content_type, form = _multipart(parts)
        _, raw = self.request("POST", path, form, content_type, token)
        return cast(Dict[str, Any], json.loads(raw))

    def producer(self, head_id: str, stream: str = "main", **options: Any) -> "Producer":
        """A :class:`Producer` on this server (options as :class:`Producer`; the token
        defaults to this client's)."""
        options.setdefault("token", self.token)
        from .producer import Producer  # the producer's module reads heads through this one

        return Producer(self.url, head_id, stream, timeout=options.pop("timeout", self.timeout),
                        **options)

    def viewer(self, head_id: str, stream: str = "main", **options: Any) -> "Viewer":
        """A :class:`Viewer` on this server (options as :class:`Viewer`)."""
        options.setdefault("token", self.token)
        from .viewer import Viewer  # the viewer's module reads meshes through this one

        return Viewer(self.url, head_id, stream, timeout=options.pop("timeout", self.timeout),
                      **options)


def _multipart(parts: Sequence[Tuple[str, Optional[str], str, bytes]]) -> Tuple[str, bytes]:
    """A ``multipart/form-data`` body of ``(name, file name, content type, bytes)`` parts,
    and its content type."""
    boundary = "facewire-" + os.urandom(16).hex()
    out = bytearray()
    for name, file_name, content_type, data in parts:
        disposition = 'form-data; name="%s"' % name
        if file_name:
            disposition += '; filename="%s"' % file_name
        out += ("--%s\r\nContent-Disposition: %s\r\nContent-Type: %s\r\n\r\n"
                % (boundary, disposition, content_type)).encode("ascii")
        out += data + b"\r\n"
    out += ("--%s--\r\n" % boundary).encode("ascii")
    return "multipart/form-data; boundary=" + boundary, bytes(out)


def material_texture(obj: str, folder: str) -> Optional[str]:
    """The path of the texture image an OBJ's material names: the first ``map_Kd`` of the
    first ``mtllib`` file (both relative to ``folder``, the OBJ's), or ``None`` when the
    OBJ names no material library or its library no ``map_Kd``. Raises
    :class:`FacewireError` naming a library or an image that is not there."""
    library = next((line.split(None, 1)[1].strip() for line in obj.splitlines()
                    if line.startswith("mtllib ") and len(line.split(None, 1)) == 2), None)
    if library is None:
        return None
    mtl_path = os.path.join(folder, library)
    try:
        with open(mtl_path, "r", encoding="utf-8", errors="replace") as f:
            mtl = f.read()
    except OSError as e:
        raise FacewireError("the OBJ names the material library %r, which cannot be read: %s"
                            % (mtl_path, e)) from None
    for line in mtl.splitlines():
        fields = line.split()
        if fields and fields[0] == "map_Kd" and len(fields) > 1:
            # Options (-o u v, -s ..., -bm ...) come first; the file name is last.
            image = os.path.join(folder, fields[-1])
            if not os.path.isfile(image):
                raise FacewireError("%s names the texture %r, which is not there" % (mtl_path, image))
            return image
    return None

