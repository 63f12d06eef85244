"""Protobuf messages as plain Python records: attribute and item access,
enums by name ("ARMED", not 2), repeated fields as lists, 64-bit integers as
int. For status replies and run listings, where a script compares names."""

from google.protobuf.descriptor import FieldDescriptor


class Record(dict):
    """A dict whose keys are also attributes: status.state, status["state"]."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


def _value(field, value):
    if field.type == FieldDescriptor.TYPE_MESSAGE:
        return as_record(value)
    if field.type == FieldDescriptor.TYPE_ENUM:
        enum = field.enum_type.values_by_number.get(value)
        return enum.name if enum is not None else value
    return value


def as_record(message):
    """Every field of the message (defaults included) as a Record."""
    out = Record()
    for field in message.DESCRIPTOR.fields:
        value = getattr(message, field.name)
        if field.label == FieldDescriptor.LABEL_REPEATED:
            if field.message_type is not None and field.message_type.GetOptions().map_entry:
                out[field.name] = {k: (as_record(v) if hasattr(v, "DESCRIPTOR") else v) for k, v in value.items()}
            else:
                out[field.name] = [_value(field, v) for v in value]
        elif field.type == FieldDescriptor.TYPE_MESSAGE and not message.HasField(field.name):
            out[field.name] = None
        else:
            out[field.name] = _value(field, value)
    return out
