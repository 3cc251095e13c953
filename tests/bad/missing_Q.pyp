*pattern
1 1 0.1
*E
0 0 1 0
