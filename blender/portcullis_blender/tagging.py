"""How a tag is written on an object: as custom properties (exported as glTF node `extras`,
the default) or as name suffixes (Godot's Rooms & Portals', and `-occupant`), where one exists."""

KINDS = [
    ("ROOM", "Room", "A room: its meshes are the room's geometry"),
    ("PORTAL", "Portal", "A portal quad in a doorway"),
    ("BOUND", "Bound", "A convex mesh that is one cell of its room"),
    ("FOOTPRINT", "Footprint", "A floor polygon extruded into its room's volume"),
    ("DETAIL", "Detail", "Rendered by its cell but neither seals nor shapes cells"),
    ("IGNORE", "Ignore", "Left out entirely"),
    ("PLAYER_START", "Player start", "Where leak searches start"),
    ("OCCUPANT", "Occupant",
     "A monster, an item, any place a player reaches: marks a block room's air, seeds leak searches"),
]

# The extras keys the tags schema knows, per kind.
KEYS = {"ROOM": "room", "PORTAL": "portal", "BOUND": "bound", "FOOTPRINT": "footprint",
        "DETAIL": "detail", "IGNORE": "ignore", "PLAYER_START": "player_start",
        "OCCUPANT": "occupant"}
SUFFIXES = {"ROOM": "-room", "PORTAL": "-portal", "BOUND": "-bound", "DETAIL": "-detail",
            "IGNORE": "-ignore", "OCCUPANT": "-occupant"}


def clear(obj):
    """Removes every tag the add-on writes (custom properties and name suffixes)."""
    for key in KEYS.values():
        if key in obj.keys():
            del obj[key]
    base = obj.name
    for suffix in SUFFIXES.values():
        if base.lower().endswith(suffix):
            base = base[: -len(suffix)]
    if "*" in base and base.lower() != obj.name.lower():
        base = base.split("*", 1)[1]  # `TARGET*NAME-portal`: the object's own name
    if base != obj.name:
        obj.name = base


def tag(obj, kind, mode="EXTRAS", value=""):
    """Tags `obj` as `kind`. `value`: a room's name (default: the object's), a portal's target
    room (default: linked by position), a footprint's room."""
    clear(obj)
    if mode == "NAMES" and kind in SUFFIXES and (kind != "PORTAL" or value):
        if kind == "ROOM":
            obj.name = f"{value or obj.name}-room"
        elif kind == "PORTAL":
            # Godot's wildcard: `TARGET*k-portal`, unique names leading to one room.
            obj.name = f"{value}*{obj.name}-portal"
        else:
            obj.name = f"{obj.name}{SUFFIXES[kind]}"
        return
    key = KEYS[kind]
    if kind in ("ROOM", "FOOTPRINT"):
        obj[key] = value or obj.name
    elif kind == "PORTAL":
        obj[key] = value if value else True
    else:
        obj[key] = True


def tag_of(obj):
    """The kind an object is tagged as by the add-on, or ''."""
    for kind, key in KEYS.items():
        if key in obj.keys():
            return kind
    name = obj.name.lower()
    for kind, suffix in SUFFIXES.items():
        if name.endswith(suffix):
            return kind
    return ""
