"""Decode the Rerun web viewer's state (``WebHandle.viewer_state()``) with protobuf.

The web viewer answers with an encoded ``GetStateResponse`` of Rerun's Viewer Control API
(``rerun/v1alpha1/viewer_control.proto``; its Python mirror is
``rerun.experimental.ViewerState``). Only the fields read here are declared; protobuf skips the
others. Field numbers are those of rerun-sdk 0.41's viewer (``viewer_version`` says which
viewer answered).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

_STRING = descriptor_pb2.FieldDescriptorProto.TYPE_STRING
_BOOL = descriptor_pb2.FieldDescriptorProto.TYPE_BOOL
_MESSAGE = descriptor_pb2.FieldDescriptorProto.TYPE_MESSAGE
_REPEATED = descriptor_pb2.FieldDescriptorProto.LABEL_REPEATED
_OPTIONAL = descriptor_pb2.FieldDescriptorProto.LABEL_OPTIONAL

# message name -> [(field name, number, type, label, message type or "")]
_MESSAGES: dict[str, list[tuple[str, int, int, int, str]]] = {
    "TimelineName": [("name", 1, _STRING, _OPTIONAL, "")],
    "Timeline": [("name", 1, _MESSAGE, _OPTIONAL, "TimelineName")],
    "Cursor": [("timeline", 1, _MESSAGE, _OPTIONAL, "TimelineName")],
    "Recording": [
        ("store_id", 1, _STRING, _OPTIONAL, ""),
        ("timelines", 2, _MESSAGE, _REPEATED, "Timeline"),
        ("cursor", 3, _MESSAGE, _OPTIONAL, "Cursor"),
    ],
    "View": [
        ("view_id", 1, _STRING, _OPTIONAL, ""),
        ("view_class", 2, _STRING, _OPTIONAL, ""),
        ("name", 3, _STRING, _OPTIONAL, ""),
        ("origin", 4, _STRING, _OPTIONAL, ""),
        ("visible", 5, _BOOL, _OPTIONAL, ""),
    ],
    "Loading": [("name", 1, _STRING, _OPTIONAL, ""), ("status", 2, _STRING, _OPTIONAL, "")],
    "GetStateResponse": [
        ("active_recording", 2, _STRING, _OPTIONAL, ""),
        ("recordings", 3, _MESSAGE, _REPEATED, "Recording"),
        ("views", 5, _MESSAGE, _REPEATED, "View"),
        ("viewer_version", 6, _STRING, _OPTIONAL, ""),
        ("loading", 7, _MESSAGE, _REPEATED, "Loading"),
    ],
}
_PACKAGE = "mcpilco_viewer_state"


def _response_class() -> type:
    file = descriptor_pb2.FileDescriptorProto(
        name=f"{_PACKAGE}.proto", package=_PACKAGE, syntax="proto3"
    )
    for name, fields in _MESSAGES.items():
        message = file.message_type.add(name=name)
        for field_name, number, kind, label, type_name in fields:
            declared = message.field.add(name=field_name, number=number, type=kind, label=label)
            if type_name:
                declared.type_name = f".{_PACKAGE}.{type_name}"
    pool = descriptor_pool.DescriptorPool()
    pool.Add(file)
    return message_factory.GetMessageClass(
        pool.FindMessageTypeByName(f"{_PACKAGE}.GetStateResponse")
    )


@dataclass(frozen=True)
class ViewerView:
    """One view of the blueprint the viewer shows."""

    view_class: str
    name: str
    origin: str
    visible: bool


@dataclass(frozen=True)
class ViewerState:
    """What the web viewer shows: its views, the active recording's timelines and the
    timeline its time cursor is on, and the sources still loading."""

    views: list[ViewerView]
    timelines: list[str]
    current_timeline: str
    loading: list[str] = field(default_factory=list)
    viewer_version: str = ""

    @property
    def view_names(self) -> list[str]:
        return [view.name for view in self.views]


def decode_viewer_state(encoded: bytes) -> ViewerState:
    """The state from the bytes of ``WebHandle.viewer_state()``.

    Raises:
        ValueError: the bytes are not a ``GetStateResponse``.
    """
    response = _response_class()()
    try:
        response.ParseFromString(encoded)
    except Exception as error:  # protobuf raises its own DecodeError
        raise ValueError(f"not a Rerun viewer state ({len(encoded)} bytes): {error}") from error
    active = [r for r in response.recordings if r.store_id == response.active_recording]
    recording = active[0] if active else (response.recordings[0] if response.recordings else None)
    return ViewerState(
        views=[ViewerView(v.view_class, v.name, v.origin, v.visible) for v in response.views],
        timelines=[] if recording is None else [t.name.name for t in recording.timelines],
        current_timeline="" if recording is None else recording.cursor.timeline.name,
        loading=[source.name for source in response.loading],
        viewer_version=response.viewer_version,
    )
