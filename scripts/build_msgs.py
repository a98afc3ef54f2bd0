#!/usr/bin/env python3
"""Build the ROS 2 interface package ``xface_msgs`` from the ROS 2 Jazzy wheels pip installs.

No colcon, no ament CMake and no ROS from apt: the rosidl generators the wheels bring
(``rosidl_adapter``, ``rosidl_generator_c``, ``rosidl_generator_py`` and the C type supports)
write the sources, a C and a C++ compiler build them against the wheels' headers and
libraries, and the result is installed into the prefix the way the wheels lay out their own
message packages (geometry_msgs, ...):

* ``<prefix>/lib/libxface_msgs__rosidl_*.so``: the C structs, the type supports (C, Fast DDS,
  introspection) and the Python conversion functions. No ``$ORIGIN`` tricks are needed for
  them: the wheels' ``ros_wheels_bootstrapper.pth`` puts ``<prefix>/lib`` on
  ``LD_LIBRARY_PATH`` (re-executing Python), and rosidl's type-support dispatch looks the
  type-support libraries up by name on that path. They also carry an RPATH to their own folder.
* ``<site-packages>/xface_msgs/``: the generated Python modules and the three extension
  modules ``xface_msgs_s__rosidl_typesupport_*.so`` that rclpy imports.
* ``<prefix>/include/xface_msgs/`` (C headers), ``<prefix>/share/xface_msgs/`` (package.xml,
  .msg/.srv/.idl/.json) and the ament index markers, as for the wheels' packages.
* ``<site-packages>/xface_msgs-<version>.dist-info``: so ``pip list`` shows it and
  ``pip uninstall xface_msgs`` removes every file above.

Usage (the interface sources are xface_ros/xface_msgs/, beside this script's repository)::

    python scripts/build_msgs.py --prefix .venv --build-dir build/xface_msgs

Idempotent: when the sources, this script, the generators' versions and the compilers are
unchanged and every installed file is present, it says so and does nothing (``--force``
rebuilds). Needs: a C and a C++ compiler (``cc``/``c++`` or ``$CC``/``$CXX``), the Python
headers of the prefix's interpreter, numpy, and the pip packages of ``ros-jazzy-rclpy`` and
``ros-jazzy-common-interfaces`` (which bring the rosidl generators). Stdlib only.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

PACKAGE = "xface_msgs"
ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIR = ROOT / "xface_ros" / PACKAGE
#: The type supports rclpy can use with the wheels' RMW (rmw_fastrtps_cpp): the C dispatcher
#: and the two it dispatches to (the names the wheels register under
#: share/ament_index/resource_index/rosidl_typesupport_c).
TYPESUPPORTS = ("rosidl_typesupport_fastrtps_c", "rosidl_typesupport_introspection_c")
#: Interfaces every service depends on (rosidl_generate_interfaces adds it by itself).
IMPLICIT_DEPENDENCIES = ("service_msgs", "builtin_interfaces")
STAMP_NAME = ".xface_msgs-build-stamp"

# Run by the prefix's Python (it has the generators): msg/srv -> .idl -> C, C type supports and
# Python sources. The .idl translation is called directly because rosidl_adapter's command-line
# extension imports catkin_pkg, which the wheels do not bring, and `rosidl generate` refuses to
# run when asked for specific generators, since the wheels register each entry point twice.
GENERATE = r"""
import json, pathlib, sys, warnings
warnings.simplefilter("ignore", DeprecationWarning)
from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_adapter.srv import convert_srv_to_idl
from rosidl_generator_c.cli import GenerateC
from rosidl_generator_py.cli import GeneratePython
from rosidl_typesupport_c.cli import GenerateCTypesupport
from rosidl_typesupport_fastrtps_c.cli import GenerateFastRTPSCTypesupport
from rosidl_typesupport_introspection_c.cli import GenerateIntrospectionCTypesupport
args = json.loads(sys.argv[1])
source, out = pathlib.Path(args["source"]), pathlib.Path(args["out"])
idl_root = out / "idl"
idl_files = []
for rel in map(pathlib.Path, args["interfaces"]):
    convert = convert_msg_to_idl if rel.suffix == ".msg" else convert_srv_to_idl
    idl = convert(source, args["package"], rel, idl_root / rel.parent)
    idl_files.append(f"{idl_root}:{idl.relative_to(idl_root).as_posix()}")
generators = {"c": GenerateC, "py": GeneratePython, "typesupport_c": GenerateCTypesupport,
              "fastrtps_c": GenerateFastRTPSCTypesupport,
              "introspection_c": GenerateIntrospectionCTypesupport}
for name, generator in generators.items():
    generator(name).generate(args["package"], idl_files, args["include_paths"],
                             output_path=out / name / args["package"])
"""

# What the prefix's Python reports about itself: where to install, what to compile against.
PROBE = r"""
import json, sys, sysconfig
from importlib import metadata
info = {"purelib": sysconfig.get_paths()["purelib"], "include": sysconfig.get_paths()["include"],
        "version": f"{sys.version_info.major}.{sys.version_info.minor}", "missing": []}
try:
    import numpy
    info["numpy_include"] = numpy.get_include()
except ImportError:
    info["missing"].append("numpy")
for module in ("rosidl_adapter", "rosidl_generator_c", "rosidl_generator_py",
               "rosidl_typesupport_c", "rosidl_typesupport_fastrtps_c",
               "rosidl_typesupport_introspection_c", "rosidl_generator_type_description", "rclpy"):
    try:
        __import__(module)
    except ImportError:
        info["missing"].append(module)
info["versions"] = sorted(f"{d.metadata['Name']}=={d.version}" for d in metadata.distributions()
                          if (d.metadata["Name"] or "").lower().startswith(("ros-", "rosidl")))
print(json.dumps(info))
"""


class BuildError(Exception):
    """A missing tool or a failed step: the message is the one line the user sees."""


@dataclass(frozen=True)
class Toolchain:
    """The prefix and what the build uses from it (all paths absolute)."""

    prefix: Path
    python: Path
    site_packages: Path
    python_include: Path
    numpy_include: Path
    cc: str
    cxx: str
    fingerprint_parts: tuple[str, ...]

    @property
    def lib(self) -> Path:
        return self.prefix / "lib"

    @property
    def include_dirs(self) -> list[Path]:
        """The wheels install each ROS package's headers under include/<package>/<package>/,
        and Fast CDR's under include/fastcdr/."""
        include = self.prefix / "include"
        return [include, *sorted(p for p in include.iterdir() if p.is_dir())]


@dataclass(frozen=True)
class Interface:
    """The package's metadata and interface files (read from its package.xml and folders)."""

    version: str
    dependencies: tuple[str, ...]
    files: tuple[str, ...]
    """Relative paths, e.g. ``msg/DockPrediction.msg``."""

    @property
    def all_dependencies(self) -> tuple[str, ...]:
        """The package.xml dependencies and those rosidl adds by itself, each once."""
        return tuple(dict.fromkeys((*self.dependencies, *IMPLICIT_DEPENDENCIES)))


def read_interface(source: Path) -> Interface:
    try:
        root = ET.parse(source / "package.xml").getroot()
    except (OSError, ET.ParseError) as error:
        raise BuildError(f"cannot read {source / 'package.xml'}: {error}") from None
    if root.findtext("name") != PACKAGE:
        raise BuildError(f"{source / 'package.xml'} does not name the package {PACKAGE}")
    deps = tuple(e.text.strip() for e in root.iter("depend") if e.text)
    files = tuple(
        p.relative_to(source).as_posix()
        for folder in ("msg", "srv")
        for p in sorted((source / folder).glob(f"*.{folder}"))
    )
    if not files:
        raise BuildError(f"no msg/*.msg or srv/*.srv under {source}")
    return Interface(root.findtext("version") or "0.0.0", deps, files)


def _compiler(env_name: str, candidates: Sequence[str], what: str) -> str:
    chosen = os.environ.get(env_name)
    for name in [chosen] if chosen else candidates:
        path = shutil.which(name)
        if path:
            return path
    names = chosen or " or ".join(candidates)
    raise BuildError(f"no {what} ({names}) on PATH: install one (Debian: apt-get install g++)")


def _compiler_version(compiler: str) -> str:
    done = subprocess.run([compiler, "--version"], capture_output=True, text=True, check=False)
    return done.stdout.splitlines()[0] if done.stdout else compiler


def find_toolchain(prefix: Path) -> Toolchain:
    """Check every tool and header the build needs; raise a one-line BuildError naming the
    first missing one."""
    python = prefix / "bin" / "python"
    if not python.exists():
        raise BuildError(f"{prefix} is not a virtual environment: no {python}")
    done = subprocess.run([str(python), "-c", PROBE], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise BuildError(f"{python} failed to start: {done.stderr.strip().splitlines()[-1:]}")
    info = json.loads(done.stdout.strip().splitlines()[-1])
    if info["missing"]:
        raise BuildError(
            f"{python} lacks {', '.join(info['missing'])}: install the ROS wheels "
            "(pip install -e '.[ros]', i.e. ros-jazzy-rclpy[fastrtps] and "
            "ros-jazzy-common-interfaces)"
        )
    python_include = Path(info["include"])
    if not (python_include / "Python.h").exists():
        raise BuildError(f"no Python.h in {python_include}: install the Python headers")
    for header in ("rosidl_runtime_c/rosidl_runtime_c/message_type_support_struct.h",
                   "fastcdr/Cdr.h"):  # fmt: skip
        if not (prefix / "include" / header).exists():
            raise BuildError(f"no {prefix / 'include' / header}: the ROS wheels are incomplete")
    cc = _compiler("CC", ("cc", "gcc", "clang"), "C compiler")
    cxx = _compiler("CXX", ("c++", "g++", "clang++"), "C++ compiler")
    parts = (*info["versions"], _compiler_version(cc), _compiler_version(cxx), info["version"])
    return Toolchain(
        prefix=prefix, python=python, site_packages=Path(info["purelib"]),
        python_include=python_include, numpy_include=Path(info["numpy_include"]),
        cc=cc, cxx=cxx, fingerprint_parts=parts,
    )  # fmt: skip


def generate(tools: Toolchain, interface: Interface, gen_dir: Path) -> None:
    """Run the rosidl generators into ``gen_dir`` (emptied first)."""
    shutil.rmtree(gen_dir, ignore_errors=True)
    include_paths = []
    for dep in interface.all_dependencies:
        share = tools.prefix / "share" / dep
        if not share.is_dir():
            raise BuildError(f"no {share}: the interface package {dep} is not installed")
        include_paths.append(str(share))
    args = {"source": str(SOURCE_DIR), "out": str(gen_dir), "package": PACKAGE,
            "interfaces": list(interface.files), "include_paths": include_paths}  # fmt: skip
    env = dict(os.environ, AMENT_PREFIX_PATH=str(tools.prefix))
    command = [str(tools.python), "-c", GENERATE, json.dumps(args)]
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        sys.stderr.write(done.stdout + done.stderr)
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise BuildError(f"the rosidl generators failed: {last}")


@dataclass(frozen=True)
class Library:
    """One shared library: its sources (globs under the generated tree) and what it links."""

    name: str
    """File name in the destination folder."""
    sources: tuple[str, ...]
    links: tuple[str, ...]
    """Library names without lib/.so; ``{dep}`` expands to every dependency package."""
    python_module: bool = False
    """An extension module installed into site-packages/xface_msgs (else into <prefix>/lib)."""


def libraries() -> list[Library]:
    """The libraries, in link order (each links those before it)."""
    p = PACKAGE
    ts_c, fast, intro = ("rosidl_typesupport_c", *TYPESUPPORTS)
    runtime = ("rosidl_runtime_c", "rcutils")
    libs = [
        Library(f"lib{p}__rosidl_generator_c.so", ("c/*/*/detail/*.c",),
                ("{dep}__rosidl_generator_c", *runtime)),
        Library(f"lib{p}__{intro}.so", ("introspection_c/*/*/detail/*.c",),
                (f"{p}__rosidl_generator_c", "{dep}__" + intro, intro, *runtime)),
        Library(f"lib{p}__{fast}.so", ("fastrtps_c/*/*/detail/*.cpp",),
                (f"{p}__rosidl_generator_c", "{dep}__" + fast, fast,
                 "rosidl_typesupport_fastrtps_cpp", "fastcdr", "rmw", *runtime)),
        Library(f"lib{p}__{ts_c}.so", ("typesupport_c/*/*/*.cpp",),
                (f"{p}__rosidl_generator_c", "{dep}__" + ts_c, ts_c, *runtime)),
        Library(f"lib{p}__rosidl_generator_py.so", ("py/*/*/_*_s.c",),
                (f"{p}__rosidl_generator_c", f"{p}__{ts_c}", "{dep}__rosidl_generator_py",
                 "{dep}__rosidl_generator_c", *runtime)),
    ]  # fmt: skip
    for ts in (ts_c, *TYPESUPPORTS):
        links = (f"{p}__rosidl_generator_py", f"{p}__{ts}", f"{p}__rosidl_generator_c", *runtime)
        libs.append(Library(f"{p}_s__{ts}.so", (f"py/*/_{p}_s.ep.{ts}.c",), links, True))
    return libs


def _compile(tools: Toolchain, source: Path, obj: Path, includes: Sequence[Path]) -> None:
    cxx = source.suffix == ".cpp"
    command = [tools.cxx if cxx else tools.cc, "-c", "-fPIC", "-O2", "-w"]
    command += ["-std=c++17"] if cxx else ["-std=c11"]
    command += [f"-I{d}" for d in includes] + [str(source), "-o", str(obj)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.stderr.write(done.stderr)
        raise BuildError(f"compiling {source.name} failed (command: {' '.join(command[:2])} ...)")


def build_libraries(
    tools: Toolchain, interface: Interface, gen_dir: Path, out_dir: Path, jobs: int
) -> list[Path]:
    """Compile every library into ``out_dir`` (objects in parallel, then the links in order)."""
    shutil.rmtree(out_dir, ignore_errors=True)
    (out_dir / "obj").mkdir(parents=True)
    gen_roots = [gen_dir / n for n in ("c", "typesupport_c", "fastrtps_c", "introspection_c")]
    includes = [*gen_roots, *tools.include_dirs, tools.python_include, tools.numpy_include]
    plan = libraries()
    jobs_list = []
    for lib in plan:
        sources = sorted({s for pattern in lib.sources for s in gen_dir.glob(pattern)})
        if not sources:
            raise BuildError(f"the generators wrote no {' '.join(lib.sources)} under {gen_dir}")
        for source in sources:
            obj = out_dir / "obj" / lib.name / (source.relative_to(gen_dir).as_posix() + ".o")
            obj.parent.mkdir(parents=True, exist_ok=True)
            jobs_list.append((lib, source, obj))
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for future in [pool.submit(_compile, tools, s, o, includes) for _, s, o in jobs_list]:
            future.result()
    built = []
    for lib in plan:
        objs = [str(o) for owner, _, o in jobs_list if owner is lib]
        names = [
            n.format(dep=dep)
            for n in lib.links
            for dep in (interface.all_dependencies if "{dep}" in n else [""])
        ]
        rpath = "$ORIGIN/../../.." if lib.python_module else "$ORIGIN"
        target = out_dir / lib.name
        command = [tools.cxx, "-shared", "-o", str(target), *objs, f"-L{out_dir}",
                   f"-L{tools.lib}", *[f"-l{n}" for n in names], f"-Wl,-rpath,{rpath}"]  # fmt: skip
        if not lib.python_module:
            command.insert(2, f"-Wl,-soname,{lib.name}")
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            sys.stderr.write(done.stderr)
            raise BuildError(f"linking {lib.name} failed: {done.stderr.strip().splitlines()[-1:]}")
        built.append(target)
    return built


def _install_plan(
    tools: Toolchain, interface: Interface, gen_dir: Path, built: Sequence[Path]
) -> dict[Path, Path]:
    """Destination -> source of every installed file (the folders are the wheels' layout)."""
    site, share = tools.site_packages / PACKAGE, tools.prefix / "share" / PACKAGE
    plan: dict[Path, Path] = {}
    for lib in built:
        plan[(site if lib.name.startswith(f"{PACKAGE}_s__") else tools.lib) / lib.name] = lib
    for module in (gen_dir / "py" / PACKAGE).glob("*/*.py"):
        plan[site / module.relative_to(gen_dir / "py" / PACKAGE)] = module
    for kind in ("c", "typesupport_c", "fastrtps_c", "introspection_c"):
        for header in (gen_dir / kind).rglob("*.h"):
            plan[tools.prefix / "include" / PACKAGE / header.relative_to(gen_dir / kind)] = header
    plan[share / "package.xml"] = SOURCE_DIR / "package.xml"
    for rel in interface.files:
        plan[share / rel] = SOURCE_DIR / rel
    for described in [*(gen_dir / "idl").rglob("*.idl"), *(gen_dir / "c").rglob("*.json")]:
        plan[share / described.parent.name / described.name] = described
    return plan


def _generated_files(tools: Toolchain, interface: Interface) -> dict[Path, bytes]:
    """Destination -> content of the files written here rather than copied."""
    site = tools.site_packages
    index = tools.prefix / "share" / "ament_index" / "resource_index"
    interfaces = sorted(
        [*interface.files, *(str(Path(f).with_suffix(".idl")) for f in interface.files)]
    )
    metadata = f"Metadata-Version: 2.1\nName: {PACKAGE}\nVersion: {interface.version}\n"
    metadata += "Summary: ROS 2 interfaces of xface, built by scripts/build_msgs.py\n"
    return {
        site / PACKAGE / "__init__.py": b"",
        index / "packages" / PACKAGE: b"",
        index / "rosidl_interfaces" / PACKAGE: "\n".join(interfaces).encode(),
        index / "package_run_dependencies" / PACKAGE: ";".join(interface.all_dependencies).encode(),
        _dist_info(tools, interface) / "METADATA": metadata.encode(),
        _dist_info(tools, interface) / "INSTALLER": b"xface scripts/build_msgs.py\n",
    }


def _dist_info(tools: Toolchain, interface: Interface) -> Path:
    return tools.site_packages / f"{PACKAGE}-{interface.version}.dist-info"


def _record_line(path: Path, site: Path) -> str:
    data = path.read_bytes()
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{os.path.relpath(path, site)},sha256={digest},{len(data)}"


def _copy_atomically(source: Path, destination: Path, content: bytes | None = None) -> None:
    """Write a new file beside the destination and rename it over: a process that has the old
    shared library mapped keeps it, and nothing is ever half written."""
    destination.parent.mkdir(parents=True, exist_ok=True)
    partial = destination.with_name(destination.name + ".partial")
    if content is None:
        shutil.copy2(source, partial)
    else:
        partial.write_bytes(content)
    os.replace(partial, destination)


def installed_files(site: Path) -> list[Path]:
    """Every file the last build installed (its RECORD), empty when there is none."""
    files = []
    for record in site.glob(f"{PACKAGE}-*.dist-info/RECORD"):
        for line in record.read_text(encoding="utf-8").splitlines():
            if line.strip():
                files.append((site / line.rsplit(",", 2)[0]).resolve())
    return files


def install(
    tools: Toolchain, interface: Interface, gen_dir: Path, built: Sequence[Path], stamp: str
) -> int:
    """Remove what the last build installed, install this build; return the file count."""
    site = tools.site_packages
    for old in installed_files(site):
        if old.is_relative_to(tools.prefix.resolve()):
            old.unlink(missing_ok=True)
    for old_info in site.glob(f"{PACKAGE}-*.dist-info"):
        shutil.rmtree(old_info)
    shutil.rmtree(site / PACKAGE, ignore_errors=True)
    written = []
    for destination, source in _install_plan(tools, interface, gen_dir, built).items():
        _copy_atomically(source, destination)
        written.append(destination)
    generated = _generated_files(tools, interface)
    generated[_dist_info(tools, interface) / STAMP_NAME] = stamp.encode()
    for destination, content in generated.items():
        _copy_atomically(destination, destination, content)
        written.append(destination)
    record = _dist_info(tools, interface) / "RECORD"
    lines = [_record_line(path, site) for path in written]
    lines.append(f"{os.path.relpath(record, site)},,")
    record.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return len(written) + 1


def fingerprint(tools: Toolchain, interface: Interface) -> str:
    """What the installed build depends on: this script, the sources, the generators' and
    compilers' versions, the prefix."""
    digest = hashlib.sha256(Path(__file__).read_bytes())
    for rel in ("package.xml", "CMakeLists.txt", *interface.files):
        digest.update(rel.encode() + b"\0" + (SOURCE_DIR / rel).read_bytes())
    digest.update("\n".join((*tools.fingerprint_parts, str(tools.prefix))).encode())
    return digest.hexdigest()


def is_up_to_date(tools: Toolchain, interface: Interface, stamp: str) -> bool:
    stamp_file = _dist_info(tools, interface) / STAMP_NAME
    try:
        if stamp_file.read_text(encoding="utf-8") != stamp:
            return False
    except OSError:
        return False
    return all(path.exists() for path in installed_files(tools.site_packages))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=f"Build {PACKAGE} from the ROS 2 wheels in a virtual environment."
    )
    parser.add_argument(
        "--prefix",
        type=Path,
        default=Path(sys.prefix),
        help="the venv to install into (default: this Python's, %(default)s)",
    )
    parser.add_argument(
        "--build-dir",
        type=Path,
        default=ROOT / "build" / PACKAGE,
        help="where the generated sources and objects go (default: %(default)s)",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="parallel compilations (default: %(default)s)",
    )
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    started, cpu_started = time.monotonic(), _children_cpu_s()
    try:
        prefix = args.prefix.absolute()
        interface = read_interface(SOURCE_DIR)
        tools = find_toolchain(prefix)
        stamp = fingerprint(tools, interface)
        if not args.force and is_up_to_date(tools, interface, stamp):
            print(f"build_msgs: {PACKAGE} {interface.version} in {prefix} is up to date")
            return 0
        build_dir = args.build_dir.absolute()
        generate(tools, interface, build_dir / "gen")
        built = build_libraries(
            tools, interface, build_dir / "gen", build_dir / "out", max(1, args.jobs)
        )
        count = install(tools, interface, build_dir / "gen", built, stamp)
    except BuildError as error:
        print(f"build_msgs: error: {error}", file=sys.stderr)
        return 1
    wall, cpu = time.monotonic() - started, _children_cpu_s() - cpu_started
    print(
        f"build_msgs: installed {PACKAGE} {interface.version} into {prefix} ({count} files) "
        f"in {wall:.1f} s wall, {cpu:.1f} s CPU"
    )
    return 0


def _children_cpu_s() -> float:
    """CPU seconds of the finished child processes (generators, compilers, linker)."""
    times = os.times()
    return times.children_user + times.children_system


if __name__ == "__main__":
    sys.exit(main())
