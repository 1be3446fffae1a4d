"""The package's version, in a module of its own: modules that record it import this, not the
package (whose lazy public names import them)."""

__version__ = "0.2.0"
