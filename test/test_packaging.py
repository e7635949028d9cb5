"""Packaging checks.

The files that make ema_phm an ament_python package that also installs with pip, and the scripts
that set it up.
"""

from __future__ import annotations

import ast
import configparser
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from importlib import metadata
from pathlib import Path

import pytest
import yaml
from helpers import setup_py_data_files

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "ema_phm"
LIB_DIR = f"$base/lib/{PACKAGE}"


def _setup_call() -> dict[str, ast.AST]:
    """Keyword arguments of the setup(...) call in setup.py, as AST nodes."""
    tree = ast.parse((ROOT / "setup.py").read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "setup":
            return {kw.arg: kw.value for kw in node.keywords if kw.arg}
    raise AssertionError("setup.py has no setup(...) call")


def _console_scripts() -> list[str]:
    tree = ast.parse((ROOT / "setup.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            getattr(t, "id", None) == "CONSOLE_SCRIPTS" for t in node.targets
        ):
            return [spec.split("=", 1)[0].strip() for spec in ast.literal_eval(node.value)]
    raise AssertionError("setup.py has no CONSOLE_SCRIPTS list")


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _pins() -> dict[str, str]:
    pins = {}
    for raw in (ROOT / "requirements.txt").read_text(encoding="utf-8").splitlines():
        line = raw.split("#", 1)[0].strip()
        if line:
            name, _, version = line.partition("==")
            pins[_norm(name)] = version
    return pins


def test_package_xml_names_ament_python_package():
    root = ET.parse(ROOT / "package.xml").getroot()
    assert root.tag == "package"
    assert root.get("format") == "3"
    assert root.findtext("name") == PACKAGE
    assert root.findtext("export/build_type") == "ament_python"
    assert root.findtext("license") == "Apache-2.0"


#: rosdep key of every third-party module the package may import (rosdep/ema_phm.yaml
#: defines the -pip keys ros/rosdistro lacks).
ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "numba": "python3-numba",
    "pymoo": "python3-pymoo-pip",
    "rosbags": "python3-rosbags-pip",
    "mcap": "python3-mcap-pip",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "rclpy": "rclpy",
    "rcl_interfaces": "rcl_interfaces",
    "std_msgs": "std_msgs",
    "diagnostic_msgs": "diagnostic_msgs",
    "std_srvs": "std_srvs",
    "trajectory_msgs": "trajectory_msgs",
    "ament_index_python": "ament_index_python",
    "builtin_interfaces": "builtin_interfaces",
    "ema_phm_msgs": "ema_phm_msgs",
    "launch": "launch",
    "launch_ros": "launch_ros",
    "dask": "python3-dask-pip",
    "distributed": "python3-distributed-pip",
    "sqlalchemy": "python3-sqlalchemy-pip",
    "threadpoolctl": "python3-threadpoolctl-pip",
    "pyarrow": "python3-pyarrow-pip",
}


def _package_modules() -> list[Path]:
    return sorted((ROOT / PACKAGE).rglob("*.py"))


def _third_party_imports(path: Path) -> set[str]:
    """Top-level names of the non-stdlib, non-relative imports of one module."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n != PACKAGE}


def test_package_xml_declares_exactly_what_the_code_imports():
    launch_files = sorted((ROOT / "launch").glob("*.launch.py"))
    imported = set().union(*(_third_party_imports(p) for p in _package_modules() + launch_files))
    unknown = sorted(imported - set(ROSDEP_KEYS))
    assert not unknown, f"imports with no rosdep key in ROSDEP_KEYS: {unknown}"
    root = ET.parse(ROOT / "package.xml").getroot()
    exec_deps = {e.text for e in root.findall("exec_depend")}
    assert exec_deps == {ROSDEP_KEYS[name] for name in imported}


def test_custom_rosdep_keys_are_defined():
    keys = yaml.safe_load((ROOT / "rosdep" / "ema_phm.yaml").read_text(encoding="utf-8"))
    root = ET.parse(ROOT / "package.xml").getroot()
    pip_keys = {
        e.text for e in root.iter() if e.tag.endswith("depend") and e.text.endswith("-pip")
    }
    assert pip_keys - {"python3-rosbags-pip"} == set(keys)  # rosbags' key exists in ros/rosdistro
    for key, rules in keys.items():
        for distro in ("debian", "ubuntu"):
            assert rules[distro]["pip"]["packages"], (key, distro)


def test_only_the_ros_subpackage_imports_ros_modules():
    ros_only = {
        "rclpy",
        "rcl_interfaces",
        "std_msgs",
        "diagnostic_msgs",
        "std_srvs",
        "trajectory_msgs",
        "builtin_interfaces",
        "ema_phm_msgs",
    }
    offenders = {
        str(p.relative_to(ROOT)): sorted(_third_party_imports(p) & ros_only)
        for p in _package_modules()
        if "ros" not in p.relative_to(ROOT / PACKAGE).parts[:1]
    }
    assert not {k: v for k, v in offenders.items() if v}


def test_package_xml_version_matches_setup_py():
    version = ET.parse(ROOT / "package.xml").getroot().findtext("version")
    assert ast.literal_eval(_setup_call()["version"]) == version


def test_setup_cfg_puts_scripts_where_ros2_run_looks():
    cfg = configparser.ConfigParser(interpolation=None)
    cfg.read(ROOT / "setup.cfg", encoding="utf-8")
    assert cfg.get("develop", "script_dir") == LIB_DIR
    assert cfg.get("install", "install_scripts") == LIB_DIR


def test_requirements_pin_every_line_exactly():
    lines = [
        line.split("#", 1)[0].strip()
        for line in (ROOT / "requirements.txt").read_text(encoding="utf-8").splitlines()
    ]
    lines = [line for line in lines if line]
    assert lines, "requirements.txt is empty"
    for line in lines:
        assert re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*==[0-9][0-9A-Za-z.+!-]*", line), (
            f"not an exact pin: {line!r}"
        )


def test_every_runtime_dependency_is_pinned():
    pins = _pins()
    install_requires = ast.literal_eval(_setup_call()["install_requires"])
    for req in install_requires:
        assert re.fullmatch(r"[A-Za-z0-9._-]+", req), (
            f"versions belong in requirements.txt: {req!r}"
        )
        assert _norm(req) in pins, f"{req} is not pinned in requirements.txt"
    assert "rclpy" not in {_norm(r) for r in install_requires}


def test_config_yaml_files_parse():
    config = ROOT / "config"
    assert config.is_dir()
    for path in sorted(config.glob("*.yaml")):
        with path.open(encoding="utf-8") as f:
            yaml.safe_load(f)  # raises on a malformed file


def test_ament_resource_marker_exists():
    assert (ROOT / "resource" / PACKAGE).is_file()


@pytest.mark.parametrize("colcon", [False, True])
def test_ros_run_wrappers_only_outside_colcon(tmp_path, colcon):
    """Under pip, setup.py adds lib/ema_phm wrappers; under colcon it must not."""
    for name in ("setup.py", "setup.cfg", "package.xml"):
        shutil.copy(ROOT / name, tmp_path / name)
    shutil.copytree(ROOT / "resource", tmp_path / "resource")
    (tmp_path / "config").mkdir()
    env = {k: v for k, v in os.environ.items() if k != "COLCON"}
    if colcon:
        env["COLCON"] = "1"
    data_files = setup_py_data_files(tmp_path, env)
    assert data_files["share/ema_phm"] == ["package.xml"]
    if colcon:
        assert f"lib/{PACKAGE}" not in data_files
    else:
        wrappers = data_files[f"lib/{PACKAGE}"]
        assert sorted(Path(w).name for w in wrappers) == sorted(_console_scripts())
        for w in wrappers:
            assert os.access(tmp_path / w, os.X_OK)


def test_front_door_scripts_are_valid_bash():
    for script in [
        "scripts/setup_env.sh",
        "scripts/demo.sh",
        "scripts/test.sh",
        "scripts/system_packages.sh",
        "scripts/fleet.sh",
        ".ci/run",
    ]:
        subprocess.run(["bash", "-n", str(ROOT / script)], check=True)


def test_readme_begins_with_front_doors():
    """The README opens (after its title) with the two commands; test_docs.py runs the rest."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```[a-z]*\n(.*?)```", text, re.S).group(1)
    assert block.splitlines() == ["bash scripts/demo.sh", "bash scripts/test.sh"]
    assert text.index("```") < text.index("\n## "), "the commands come before any section"


def _installed_here():
    """The ema_phm distribution if installed into this interpreter's prefix."""
    try:
        dist = metadata.distribution(PACKAGE)
    except metadata.PackageNotFoundError:
        return None
    if not any(ep.name == "ema-phm" for ep in dist.entry_points.select(group="console_scripts")):
        return None
    location = Path(dist.locate_file("")).resolve()
    if not location.is_relative_to(Path(sys.prefix).resolve()):
        return None  # e.g. a colcon install dir on PYTHONPATH
    return dist


@pytest.mark.skipif(
    _installed_here() is None, reason="ema_phm is not installed in this interpreter"
)
def test_console_script_installed_next_to_interpreter():
    script = Path(sys.executable).parent / "ema-phm"
    assert script.is_file() and os.access(script, os.X_OK)


@pytest.mark.skipif(
    _installed_here() is None, reason="ema_phm is not installed in this interpreter"
)
def test_ros_run_wrappers_installed_in_prefix():
    for name in _console_scripts():
        wrapper = Path(sys.prefix) / "lib" / PACKAGE / name
        assert wrapper.is_file() and os.access(wrapper, os.X_OK), wrapper


def test_no_module_outside_ros_loads_rclpy():
    """Importing every module outside ema_phm/ros/ (in one fresh interpreter) loads no rclpy."""
    names = [
        ".".join(p.relative_to(ROOT).with_suffix("").parts)
        for p in _package_modules()
        if p.relative_to(ROOT / PACKAGE).parts[0] != "ros"
    ]
    names = [n.removesuffix(".__init__") for n in names]
    assert len(names) > 15
    code = (
        "import importlib, sys\n"
        f"for n in {names!r}: importlib.import_module(n)\n"
        "sys.exit('rclpy' in sys.modules)"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
