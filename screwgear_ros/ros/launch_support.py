"""What the launch files need before they start anything, for the ``ros2 launch`` process.

Light on purpose: the standard library, PyYAML and ament_index_python only (no rclpy, no
numba, nothing of the model), so that ``ros2 launch`` loads no more than it uses.

* :func:`ros2_control_needs`: the packages ``ros2_control.launch.py`` runs something
  from: its processes (with their executables), the URDF's hardware plugin, the
  controllers' types in ``config/ros2_control.yaml`` (a pluginlib name ``package/Class``
  lives in ``package``), each with the minimum version this package's ``package.xml``
  declares (``version_gte``).
* :func:`unmet`: of those, the ones an index lookup (name → version, None: not found) does
  not have or has too old, or whose executables are not where ``ros2 launch`` looks.
  :func:`require` raises :class:`MissingPackages` naming them all and how to install
  them. Every executable is checked too because launch starts each process as it gets
  to it: one that failed after table_sim had been started left table_sim running.
* :func:`urdf_namespace` and :func:`in_namespace`: the namespace a URDF's ros2_control
  block points the topic hardware interface at, and that URDF pointed at another one.
* :func:`require_params_file`: a parameter file that is not there is refused before
  anything starts (launch_ros only warns and starts the node with its defaults).
* :class:`ExitWatch`: what ends a launch when a process it started exits with an error,
  with the process's last error line as the reason (launch then returns non-zero and
  stops every other process it started); :func:`watched` registers it with launch.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import yaml

from screwgear_ros.errors import ScrewgearError

#: The hardware parameters of the topic hardware interface that name table_sim's topics.
TOPIC_PARAMS = ('joint_commands_topic', 'joint_states_topic')


@dataclass(frozen=True)
class Need:
    """A package a launch runs something from, and the oldest version that works."""

    package: str
    minimum: str | None = None
    executables: tuple[str, ...] = ()


@dataclass(frozen=True)
class Unmet:
    """A need the install does not meet: ``found`` is None when the package is missing."""

    need: Need
    found: str | None
    missing_executables: tuple[str, ...] = ()

    def __str__(self) -> str:
        if self.found is None:
            return f'{self.need.package}: not found'
        if self.missing_executables:
            return (f'{self.need.package}: installed without '
                    f'{", ".join(self.missing_executables)} in lib/{self.need.package}')
        return f'{self.need.package}: {self.found} installed, needs >= {self.need.minimum}'


class MissingPackages(ScrewgearError, RuntimeError):
    """A launch cannot run: the message lists every unmet need and how to install it."""


class LaunchRefused(ScrewgearError, RuntimeError):
    """A launch ends before or while it runs: a parameter file that is not there, or a
    process that exited with an error (the message says which and why)."""


def require_params_file(path: str) -> str:
    """``path`` if it is a readable file; :class:`LaunchRefused` otherwise.

    Examples
    --------
    >>> require_params_file('/no/such/table.yaml')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    screwgear_ros.ros.launch_support.LaunchRefused: params_file /no/such/table.yaml is ...
    """
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise LaunchRefused(f'params_file {path} is not a file; nothing was started')
    return path


_COLOUR = re.compile(r'\x1b\[[0-9;]*m')


class ExitWatch:
    """The last error line of each process, and the refusal when one exits non-zero.

    A launch file feeds :meth:`saw` each ``ProcessIO`` event of stderr and calls
    :meth:`check` on each ``ProcessExited`` event; :meth:`check` raises
    :class:`LaunchRefused` for a non-zero code, which ``ros2 launch`` reports as
    ``Caught exception in launch`` before it stops everything and returns 1.

    Examples
    --------
    >>> watch = ExitWatch()
    >>> watch.saw('table_sim-1', b'[FATAL] [table_sim]: cannot start: x exists\\n')
    >>> watch.check('table_sim-1', 0)
    >>> watch.check('table_sim-1', 2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    screwgear_ros.ros.launch_support.LaunchRefused: table_sim-1 exited with code 2: [FATAL] ...
    """

    def __init__(self) -> None:
        self._last: dict[str, str] = {}

    def saw(self, process: str, text: bytes) -> None:
        # the node colours its lines on launch's pseudo-terminal: the reason drops that
        plain = _COLOUR.sub('', text.decode(errors='replace'))
        lines = [line.strip() for line in plain.splitlines()]
        lines = [line for line in lines if line]
        if lines:
            self._last[process] = lines[-1]

    def check(self, process: str, returncode: int | None) -> None:
        # a signal a stop sent (Ctrl-C, launch's own SIGTERM) is no error: Python
        # nodes exit 0 or -2/-15 then
        if returncode in (0, None, -2, -15):
            return
        said = self._last.get(process)
        raise LaunchRefused(f'{process} exited with code {returncode}'
                            + (f': {said}' if said else ''))


def watched(action: object, watch: ExitWatch | None = None) -> list[object]:
    """The launch actions that end a launch when ``action`` (a process it starts) exits
    with an error: an :class:`ExitWatch` fed by launch's ``OnProcessIO`` and
    ``OnProcessExit`` handlers. Put them before ``action`` in the description.

    Imports ``launch`` when called, from the ``ros2 launch`` process that has it.
    """
    from launch.actions import RegisterEventHandler
    from launch.event_handlers import OnProcessExit, OnProcessIO
    watch = watch or ExitWatch()
    return [
        RegisterEventHandler(OnProcessIO(
            target_action=action, on_stderr=lambda e: watch.saw(e.process_name, e.text))),
        RegisterEventHandler(OnProcessExit(
            target_action=action,
            on_exit=lambda e, context: watch.check(e.process_name, e.returncode))),
    ]


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r'\d+', text)[:3])


def minimum_versions(package_xml: str) -> dict[str, str]:
    """exec_depend name → its ``version_gte``, from a package.xml's text."""
    found = {}
    for element in ET.fromstring(package_xml).iter('exec_depend'):
        version = element.get('version_gte')
        if element.text and version:
            found[element.text.strip()] = version
    return found


def plugin_package(lookup_name: str) -> str:
    """The package of a pluginlib lookup name ``package/Class``."""
    package, slash, _ = lookup_name.partition('/')
    if not slash or not package:
        raise ValueError(f'{lookup_name!r} is not a pluginlib name package/Class')
    return package


def ros2_control_needs(processes: Iterable[tuple[str, str]], urdf: str,
                       controllers_yaml: str, package_xml: str) -> list[Need]:
    """What ros2_control.launch.py needs (see the module docstring), in a stable order;
    ``processes`` are the (package, executable) pairs it starts."""
    block = ET.fromstring(urdf).find('ros2_control')
    plugins = [block.findtext('hardware/plugin', default='').strip()] if block is not None else []
    manager = (yaml.safe_load(controllers_yaml) or {}).get('controller_manager', {})
    for entry in manager.get('ros__parameters', {}).values():
        if isinstance(entry, dict) and 'type' in entry:
            plugins.append(entry['type'])
    processes = list(processes)
    names = list(dict.fromkeys([*(package for package, _ in processes),
                                *(plugin_package(p) for p in plugins)]))
    minimum = minimum_versions(package_xml)
    return [Need(name, minimum.get(name),
                 tuple(dict.fromkeys(exe for package, exe in processes if package == name)))
            for name in names]


def unmet(needs: Iterable[Need], lookup: Callable[[str], str | None],
          has_executable: Callable[[str, str], bool] = lambda package, exe: True
          ) -> list[Unmet]:
    """The needs ``lookup`` (package → installed version, None: not installed) and
    ``has_executable`` (package, executable → found where launch looks) miss."""
    out = []
    for need in needs:
        found = lookup(need.package)
        if found is None:
            out.append(Unmet(need, None))
            continue
        missing = tuple(e for e in need.executables if not has_executable(need.package, e))
        if missing or (need.minimum and found and
                       _version(found) < _version(need.minimum)):
            out.append(Unmet(need, found, missing))
    return out


def installed_version(package: str) -> str | None:
    """The version of ``package`` in the ament index (its package.xml), None if absent;
    '' when it is there without a readable package.xml."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    try:
        share = get_package_share_directory(package)
    except (PackageNotFoundError, ValueError, LookupError):
        return None
    try:
        with open(os.path.join(share, 'package.xml'), encoding='utf-8') as f:
            return (ET.fromstring(f.read()).findtext('version') or '').strip()
    except (OSError, ET.ParseError):
        return ''


def installed_executable(package: str, executable: str) -> bool:
    """Whether ``executable`` is in ``<prefix>/lib/<package>/``, where ``ros2 launch``
    and ``ros2 run`` look for it."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    try:
        path = os.path.join(get_package_prefix(package), 'lib', package, executable)
    except (PackageNotFoundError, ValueError, LookupError):
        return False
    return os.path.isfile(path) and os.access(path, os.X_OK)


def message(launch: str, problems: Iterable[Unmet], share: str,
            distro: str | None = None) -> str:
    """What to tell the user: every unmet need, and the commands that install them."""
    problems = list(problems)
    distro = distro or os.environ.get('ROS_DISTRO') or 'jazzy'
    apt = ' '.join(f'ros-{distro}-{p.need.package.replace("_", "-")}' for p in problems)
    lines = [(f'{launch} needs packages this ROS 2 install does not have; nothing was '
              'started:')]
    lines += [f'  {p}' for p in problems]
    lines += ['install them with:', f'  sudo apt install {apt}',
              'or every dependency of this package with:',
              f'  rosdep install --from-paths {share} --ignore-src -y']
    return '\n'.join(lines)


def require(launch: str, needs: Iterable[Need], share: str,
            lookup: Callable[[str], str | None] = installed_version,
            has_executable: Callable[[str, str], bool] = installed_executable) -> None:
    """Raise :class:`MissingPackages` unless every need is met."""
    problems = unmet(needs, lookup, has_executable)
    if problems:
        raise MissingPackages(message(launch, problems, share))


def _topics(urdf: str) -> tuple[ET.Element, dict[str, ET.Element]]:
    root = ET.fromstring(urdf)
    params = {e.get('name'): e for e in root.iterfind('ros2_control/hardware/param')}
    missing = [name for name in TOPIC_PARAMS if name not in params]
    if missing:
        raise ValueError(f'the URDF\'s ros2_control hardware has no {", ".join(missing)}')
    return root, {name: params[name] for name in TOPIC_PARAMS}


def urdf_namespace(urdf: str) -> str:
    """The namespace whose topics the URDF's ros2_control block names (``/screwgear``)."""
    _, params = _topics(urdf)
    spaces = {(e.text or '').strip().rpartition('/')[0] for e in params.values()}
    if len(spaces) != 1:
        raise ValueError(f'the URDF\'s topics are in different namespaces: {sorted(spaces)}')
    return spaces.pop() or '/'


def normalized_namespace(namespace: str) -> str:
    """``axis_c`` → ``/axis_c``, as the node's own namespace resolves. The root is
    refused: there the node's joint_states would be joint_state_broadcaster's."""
    resolved = '/' + namespace.strip().strip('/')
    if resolved == '/':
        raise ValueError('table_sim under ros2_control needs a namespace other than /: '
                         'there its joint_states would collide with '
                         'joint_state_broadcaster\'s /joint_states')
    return resolved


def in_namespace(urdf: str, namespace: str) -> str:
    """The URDF with its ros2_control block pointed at table_sim in ``namespace``
    (unchanged if it already is)."""
    namespace = normalized_namespace(namespace)
    if urdf_namespace(urdf) == namespace:
        return urdf
    root, params = _topics(urdf)
    for element in params.values():
        element.text = namespace + '/' + (element.text or '').strip().rpartition('/')[2]
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding='unicode') + '\n'


def read(path: str) -> str:
    with open(path, encoding='utf-8') as f:
        return f.read()


__all__ = [
    'TOPIC_PARAMS',
    'ExitWatch',
    'LaunchRefused',
    'MissingPackages',
    'Need',
    'Unmet',
    'in_namespace',
    'installed_executable',
    'installed_version',
    'message',
    'minimum_versions',
    'normalized_namespace',
    'plugin_package',
    'read',
    'require',
    'require_params_file',
    'ros2_control_needs',
    'unmet',
    'urdf_namespace',
    'watched',
]
