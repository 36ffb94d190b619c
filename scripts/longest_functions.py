#!/usr/bin/env python3
"""The longest functions of the C++ sources (base, topology, forcefields, src, python), by lines
from the signature to the closing brace: a heuristic over the text (no parser), good enough to
see which functions grow. Usage: scripts/longest_functions.py [N] (default 12), from the tree's
root (it lists the files git tracks)."""
import re
import subprocess
import sys

files=subprocess.run(["git","ls-files","*.cpp","*.hpp"],capture_output=True,text=True).stdout.split()
files=[f for f in files if f.split("/")[0] in ("base","topology","forcefields","src","python")]
res=[]
sig=re.compile(r'^(\s{0,4})(?!if\b|for\b|while\b|switch\b|return\b|else\b|namespace\b|class\b|struct\b)[A-Za-z_~][\w:<>,\s\*&~\[\]]*\([^;]*$')
for f in files:
    L=open(f).read().split("\n")
    i=0
    while i<len(L):
        m=sig.match(L[i])
        if m and not L[i].strip().startswith("//"):
            # find the opening brace within 4 lines
            j=i
            while j<len(L) and j<i+6 and "{" not in L[j] and ";" not in L[j]: j+=1
            if j<len(L) and "{" in L[j] and ";" not in L[j].split("{")[0]:
                depth=0; k=j
                while k<len(L):
                    depth+=L[k].count("{")-L[k].count("}")
                    if depth<=0 and k>=j: break
                    k+=1
                n=k-i+1
                name=re.search(r'([~\w:]+)\s*\(',L[i])
                res.append((n,f,i+1,name.group(1) if name else L[i].strip()[:40]))
                i=k+1; continue
        i+=1
res.sort(reverse=True)
for r in res[:int(sys.argv[1]) if len(sys.argv)>1 else 12]: print("%5d  %s:%d  %s"%r)
