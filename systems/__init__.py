"""rpod.systems"""
