def render_results(arg):
    return "TODO"
