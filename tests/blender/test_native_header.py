"""The ctypes binding (``blender_addon/transcut``) mirrors include/transcut.h: every function its
``_abi`` module binds is declared there with the same parameter and return types, the structs
have the same fields in the same order and the sizes and offsets of the header's layout checks,
and every constant has the same value and is exported by the package. Needs no library and no
Blender; reads the committed header.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import re
import sys
from pathlib import Path

import pytest

from conftest import ADDON_SRC, REPO

HEADER = Path(os.environ.get("TRANSCUT_HEADER", REPO / "include" / "transcut.h"))


def load_binding():
    """The package ``blender_addon/transcut`` imported from the source folder, on its own."""
    folder = ADDON_SRC / "transcut"
    name = "transcut_binding_under_test"
    spec = importlib.util.spec_from_file_location(
        name, folder / "__init__.py", submodule_search_locations=[str(folder)]
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # its relative imports look it up there
    spec.loader.exec_module(mod)
    return mod


binding = load_binding()
abi = binding._abi


def header_text() -> str:
    if not HEADER.is_file():
        pytest.fail(f"{HEADER} is missing (the C ABI's generated header is committed)")
    text = HEADER.read_text()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def c_type(decl: str) -> str:
    """A parameter or return declaration without its name, normalised ('const struct TcMedium *')."""
    decl = " ".join(decl.replace("*", " * ").split())
    return decl.replace("* *", "**")


def strip_name(param: str) -> str:
    param = param.strip()
    m = re.match(r"^(.*?)([A-Za-z_][A-Za-z_0-9]*)(\s*\[\s*\d+\s*\])?$", param)
    assert m, param
    base, _, array = m.groups()
    return c_type(base + (" *" if array else ""))


def declarations() -> dict:
    """name → (return type, [parameter types]) for every function in the header."""
    out = {}
    pattern = re.compile(r"([A-Za-z_][A-Za-z_0-9 \*]*?)\b(tc_[a-z_0-9]+)\s*\(([^)]*)\)\s*;")
    for ret, name, params in pattern.findall(header_text()):
        params = params.strip()
        plist = [] if params in ("", "void") else [strip_name(p) for p in params.split(",")]
        out[name] = (c_type(ret), plist)
    return out


def ctypes_name(t) -> str:
    """The C spelling a ctypes type stands for (constness dropped on both sides)."""
    if t is None:
        return "void"
    simple = {
        ctypes.c_int32: "int32_t",
        ctypes.c_uint32: "uint32_t",
        ctypes.c_uint64: "uint64_t",
        ctypes.c_uint8: "uint8_t",
        ctypes.c_size_t: "size_t",
        ctypes.c_double: "double",
        ctypes.c_float: "float",
        ctypes.c_char_p: "char *",
        ctypes.c_void_p: "void *",
    }
    if t in simple:
        return simple[t]
    if isinstance(t, type) and issubclass(t, ctypes.Structure):
        return f"struct {t.__name__}"
    if t is abi.TcProgressFn:
        return "TcProgressFn"
    if t is abi.ScenePtr:
        return "struct TcScene *"
    if hasattr(t, "_type_") and isinstance(t._type_, type):
        inner = t._type_
        if inner is abi.ScenePtr:
            return "struct TcScene **"
        if issubclass(inner, ctypes.Structure):
            return f"struct {inner.__name__} *"
        return ctypes_name(inner) + " *"
    raise AssertionError(f"no C spelling for {t}")


def normalise(c: str) -> str:
    c = c.replace("const ", "").replace("TcStatus", "int32_t")
    if ctypes.c_size_t is ctypes.c_uint64:  # one ctypes type for both on LP64 platforms
        c = c.replace("size_t", "uint64_t")
    return " ".join(c.split()).replace(" *", " *").replace("struct TcScene*", "struct TcScene *")


def test_every_bound_function_matches_the_header():
    decls = declarations()
    assert "tc_scene_bake" in decls, "header parse failed"
    for name, (restype, argtypes) in {**abi.REQUIRED, **abi.OPTIONAL}.items():
        if name not in decls and name in abi.OPTIONAL:
            continue  # optional: not in this header version
        assert name in decls, f"{name} is bound by the binding but not declared in transcut.h"
        ret, params = decls[name]
        assert normalise(ret) == normalise(ctypes_name(restype)), f"{name}: returns {ret}"
        got = [normalise(ctypes_name(a)) for a in argtypes]
        want = [normalise(p) for p in params]
        assert got == want, f"{name}: header ({', '.join(want)}) vs the binding ({', '.join(got)})"


def header_struct(name: str) -> list:
    m = re.search(rf"typedef struct {name} \{{(.*?)\}} {name};", header_text(), flags=re.S)
    assert m, f"struct {name} not in the header"
    fields = []
    for line in m.group(1).split(";"):
        line = " ".join(line.replace("*", " * ").split())
        if not line:
            continue
        fm = re.match(r"^(.*?)\s+([A-Za-z_0-9]+)(\[(\d+)\])?$", line)
        assert fm, line
        ctype, fname, _, count = fm.groups()
        fields.append((fname, ctype, int(count) if count else None))
    return fields


STRUCTS = [
    binding.TcMedium,
    binding.TcArtistMedium,
    binding.TcBakeOptions,
    binding.TcTransCutOptions,
    binding.TcDipoleOptions,
    binding.TcBakeStats,
    binding.TcDipoleStats,
    binding.TcRadiosityOptions,
    binding.TcPrtOptions,
    binding.TcPrtStats,
    binding.TcPolygridOptions,
    binding.TcPolygridStats,
    binding.TcRadiosityStats,
    binding.TcMediumEdit,
    binding.TcEditStats,
    binding.TcAcquireOptions,
    binding.TcAcquireStats,
]


@pytest.mark.parametrize("struct", STRUCTS)
def test_structs_match_the_header(struct):
    want = header_struct(struct.__name__)
    got = []
    for fname, ftype in struct._fields_:
        if issubclass(ftype, ctypes.Array):
            got.append((fname, normalise(ctypes_name(ftype._type_)), ftype._length_))
        else:
            got.append((fname, normalise(ctypes_name(ftype)), None))
    assert got == [(f, normalise(t), n) for f, t, n in want]


def layout_checks() -> dict:
    """struct name → {"__sizeof": bytes, field: offset} from the header's TC_LAYOUT_CHECK lines."""
    out: dict = {}
    text = header_text()
    for name, size in re.findall(r"TC_LAYOUT_CHECK\(\w+, sizeof\((\w+)\) == (\d+)\)", text):
        out.setdefault(name, {})["__sizeof"] = int(size)
    for name, fname, offset in re.findall(r"TC_LAYOUT_CHECK\(\w+, offsetof\((\w+), (\w+)\) == (\d+)\)", text):
        out.setdefault(name, {})[fname] = int(offset)
    return out


def test_struct_layouts_match_the_header_checks():
    """ctypes lays every struct out as the library's build does (the sizes and offsets the header
    asserts), and every struct the header checks is mirrored: a struct shorter than the library's
    would be filled and read only in part (``tc_bake_options_init`` is given its size)."""
    checks = layout_checks()
    assert "TcBakeOptions" in checks and "TcDipoleStats" in checks, "header parse failed"
    assert sorted(checks) == sorted(s.__name__ for s in STRUCTS)
    for struct in STRUCTS:
        got = {"__sizeof": ctypes.sizeof(struct), **{f: getattr(struct, f).offset for f, _ in struct._fields_}}
        assert got == checks[struct.__name__], struct.__name__


def test_direct_client_options_fill_the_library_struct():
    """The tests' independent client (capi_direct) has the whole ``TcBakeOptions`` of the header, so
    ``tc_bake_options_init`` fills every field the library knows."""
    import capi_direct

    assert ctypes.sizeof(capi_direct.Options) == layout_checks()["TcBakeOptions"]["__sizeof"]


def test_status_codes_match_the_header():
    defines = dict((k, int(v)) for k, v in re.findall(r"#define (TC_[A-Z_]+) (\d+)", header_text()))
    for value, name in binding.STATUS_NAMES.items():
        assert defines.get(name) == value, name
        assert getattr(binding, name, None) == value, f"{name} = {value} in transcut.h, not exported by the binding"
    # Every other constant (TC_METHOD_*, TC_BACKEND_*, ...) is mirrored by the binding with its value.
    others = {
        k: v for k, v in defines.items() if k not in binding.STATUS_NAMES.values() and not k.startswith("TC_LAYOUT")
    }
    assert "TC_METHOD_TRANSCUT" in others, "header parse failed"
    for name, value in others.items():
        got = getattr(binding, name, None)
        assert got == value, f"{name} = {value} in transcut.h, {got} in the binding"


def test_native_binds_every_header_function():
    bound = set(abi.REQUIRED) | set(abi.OPTIONAL)
    missing = {n for n in declarations() if not n.startswith("tc_debug_")} - bound
    assert not missing, f"declared in transcut.h but not mirrored by the binding: {sorted(missing)}"
