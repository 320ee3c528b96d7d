"""What the tools share: matplotlib behind the 'charts' extra."""


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend; a clear message if the 'charts' extra is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("this tool needs the 'charts' extra: pip install 'pyrt-embree[charts]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def finish_error_time_axes(ax, title, legend_size=8, ncol=1):
    """A relMSE-against-time panel's title, axis labels, grid and legend (the chart tools' common finish)."""
    ax.set_title(title)
    ax.set_xlabel("render time (s, median)")
    ax.set_ylabel("relMSE vs reference")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=legend_size, ncol=ncol)


def save_figure(fig, title, path):
    """Suptitle, tight layout, write ``path`` at 80 dpi and say so."""
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")
