"""The package's one error base.

Every exception screwgear_ros raises derives from :class:`ScrewgearError`, and also from
the built-in it specializes where that helps a caller (a bad value is a ``ValueError``,
a file that cannot be read an ``OSError``). So ``except ScrewgearError`` catches what the
package refuses, and nothing else; the kind of an error is its class.

Examples
--------
>>> from screwgear_ros.errors import ScrewgearError
>>> from screwgear_ros import ParameterError
>>> issubclass(ParameterError, ScrewgearError) and issubclass(ParameterError, ValueError)
True
"""

from __future__ import annotations


class ScrewgearError(Exception):
    """Base of every exception the package raises."""
