"""rpod.planners"""
