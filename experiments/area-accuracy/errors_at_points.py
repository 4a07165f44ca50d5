import sys,csv
ref=[l.split(',') for l in open(sys.argv[1]).read().split('\n')[2:] if l]
est=list(csv.DictReader(open(sys.argv[2])))
R=[(float(r[9])+float(r[10])+float(r[11]))/3 for r in ref]
SE=[(float(r[15])+float(r[16])+float(r[17]))/3 for r in ref]
RR=[(float(r[9]),float(r[10]),float(r[11])) for r in ref]
E=[(float(e['indirect_r']),float(e['indirect_g']),float(e['indirect_b'])) for e in est]
mean=sum(R)/len(R); e2=r2=0; ratios=[]; se=sr=0; leak=0; nb=0
for rv,s,r3,e3 in zip(R,SE,RR,E):
    em=sum(e3)/3
    if rv<0.01*mean or rv<=0: nb+=1; leak+=max(em,0); continue
    if s>0.05*rv: continue
    e2+=sum((a-b)**2 for a,b in zip(e3,r3)); r2+=sum(b*b for b in r3); ratios.append(em/rv); se+=em; sr+=rv
ratios.sort(); k=len(ratios)
med=ratios[k//2] if k%2 else 0.5*(ratios[k//2-1]+ratios[k//2])
off=sum(1 for q in ratios if q>3 or q<1/3)
print(f"rel_rms {100*(e2/r2)**.5:.2f}%  median {med:.3f}  mean {sum(ratios)/k:.3f} energy {se/sr:.3f} off3x {off} of {k} leak {leak/max(nb,1)/mean:.4f} below {nb}")
