"""The package's version, in a bottom module: provenance reads it without importing the
package root."""

__version__ = "0.2.0"
