"""Texel-by-texel relative error of one bake's light maps against another's (luxbake's own
1 024-sample bake with every shadow ray as the reference: this separates the estimators' noise,
not their bias, which `bench nearfield` measures against Radiance).

usage: compare_direct.py REFERENCE_DIR TEST_DIR [STAGE]   (STAGE: direct, the default, or
illuminance). Texels of at least 0.1 % of the reference's peak, per surface kind (the room;
the furniture), Rec. 709 luminance of the RGB maps. Needs numpy and OpenEXR.
"""
import OpenEXR, Imath, numpy as np, sys, glob, os
def load(f):
    e=OpenEXR.InputFile(f); dw=e.header()['dataWindow']; w=dw.max.x-dw.min.x+1; h=dw.max.y-dw.min.y+1
    ch=[np.frombuffer(e.channel(c, Imath.PixelType(Imath.PixelType.FLOAT)),dtype=np.float32).reshape(h,w) for c in 'RGB']
    return 0.2126*ch[0]+0.7152*ch[1]+0.0722*ch[2]
ref, test = sys.argv[1], sys.argv[2]
stage = sys.argv[3] if len(sys.argv)>3 else 'direct'
refs={os.path.basename(f).replace('_%s.exr'%stage,''):load(f) for f in glob.glob(ref+'/*_%s.exr'%stage)}
peak=max(v.max() for v in refs.values())
groups={'room':[], 'furniture':[]}
for k,r in refs.items():
    t=load(test+'/'+k+'_%s.exr'%stage)
    m=(r>1e-3*peak)
    rel=(t[m]-r[m])/r[m]
    groups['room' if k=='room' else 'furniture'].append(rel)
out=[]
for g,v in groups.items():
    v=np.concatenate(v)
    out.append('%s n=%d mean|rel| %.3f%% bias %+.3f%% p99 %.2f%% max %.1f%%'%(g,len(v),100*np.abs(v).mean(),100*v.mean(),100*np.percentile(np.abs(v),99),100*np.abs(v).max()))
v=np.concatenate([np.concatenate(x) for x in groups.values()])
out.append('all n=%d mean|rel| %.3f%% bias %+.3f%% p99 %.2f%%'%(len(v),100*np.abs(v).mean(),100*v.mean(),100*np.percentile(np.abs(v),99)))
print(test, ' | '.join(out))
